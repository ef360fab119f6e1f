// DDS Security for the dygslam participants, with Fast DDS's builtin plugins:
//   authentication  builtin.PKI-DH            (X.509 identity certificates, one CA)
//   access control  builtin.Access-Permissions (signed governance + per-identity permissions)
//   encryption      builtin.AES-GCM-GMAC      (what the governance asks: ENCRYPT everywhere)
// Test credentials: scripts/make_dds_certs.sh OUT_DIR -> OUT_DIR/<name>/ holds the files
// FromDirectory() expects. Debian's libfastrtps 2.9.1 is built with security (HAVE_SECURITY 1,
// PKIDH / Permissions / AESGCMGMAC symbols present); SecurityPluginsAvailable() says so at run
// time.
//
//   dds::SecurityOptions sec = dds::SecurityOptions::FromEnvironment();  //
//   DYGSLAM_DDS_SECURITY_DIR dds::ApplySecurity(sec, &participant_qos);                          //
//   before create_participant
//
// With security on, a participant without valid credentials (none, or from another CA) is not
// authenticated: it discovers nothing and receives no samples of the secured domain.
#pragma once

#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>
#include <string>
#include <utility>
#include <vector>

namespace dygslam::dds {

struct SecurityOptions {
  bool enabled = false;
  std::string identity_ca;           // PEM: CA that issued the identities of the domain
  std::string identity_certificate;  // PEM: this participant's certificate
  std::string private_key;           // PEM: its private key (unencrypted)
  std::string permissions_ca;        // PEM: CA that signed governance + permissions
  std::string governance;            // S/MIME signed governance document
  std::string permissions;           // S/MIME signed permissions of this identity
  bool encrypt = true;               // load the AES-GCM-GMAC plugin (governance decides what)

  // A directory in the layout of scripts/make_dds_certs.sh: ca_cert.pem, cert.pem, key.pem,
  // governance.smime, permissions.smime. Throws InputError naming the first missing file.
  static SecurityOptions FromDirectory(const std::string& directory);
  // FromDirectory($DYGSLAM_DDS_SECURITY_DIR) when the variable is set and not empty, else
  // disabled options.
  static SecurityOptions FromEnvironment();

  // When enabled: every file set and readable (InputError naming the option and file); the
  // identity certificate issued by the identity CA and valid now (InputError naming both files:
  // authentication would fail, and Fast DDS would only stall); InvalidOptions if the Fast DDS
  // library was built without security.
  void Check() const;
};

// The credentials of the participants of one run (name, options): every enabled one must trust the
// same identity CA, or they cannot authenticate each other (Fast DDS then stalls discovery
// without a message). Throws InputError naming the two components and their CA files.
void CheckSameIdentityCa(const std::vector<std::pair<std::string, SecurityOptions>>& participants);

// True when the Fast DDS library provides the builtin security plugins.
bool SecurityPluginsAvailable();

// Adds the dds.sec.* properties to the participant QoS (nothing when !options.enabled).
// Runs options.Check() first.
void ApplySecurity(const SecurityOptions& options,
                   eprosima::fastdds::dds::DomainParticipantQos* qos);

}  // namespace dygslam::dds
