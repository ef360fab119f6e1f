#include "components/dds/security.h"

#include <fastrtps/config.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/x509.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>

#include "core/base/error.h"
#include "core/base/input_file.h"

namespace dygslam::dds {
namespace {
namespace fs = std::filesystem;

void RequireFile(const std::string& option, const std::string& path) {
  if (path.empty()) throw InputError("DDS Security: " + option + " is not set");
  std::error_code ec;
  if (const std::string reason = NotRegularFileReason(path); !reason.empty())
    throw InputError(path, 0, "DDS Security " + option + ": " + reason);
  if (!fs::is_regular_file(path, ec))
    throw InputError(path, 0, "DDS Security " + option + ": file not found");
  std::ifstream in(path);
  if (!in.good()) throw InputError(path, 0, "DDS Security " + option + ": cannot read the file");
}

// An encrypted key is not asked for a passphrase on the terminal (the participant could not use
// it either): it reads as no key.
int NoPassphrase(char* /*buffer*/, int /*size*/, int /*rwflag*/, void* /*user*/) { return 0; }

struct X509Free {
  void operator()(X509* x) const { X509_free(x); }
};
using X509Ptr = std::unique_ptr<X509, X509Free>;

// The first certificate of a PEM file; InputError naming the file when there is none.
X509Ptr ReadCertificate(const std::string& option, const std::string& path) {
  std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "r"), &std::fclose);
  if (!file) throw InputError(path, 0, "DDS Security " + option + ": cannot read the file");
  X509Ptr cert(PEM_read_X509(file.get(), nullptr, nullptr, nullptr));
  if (!cert) throw InputError(path, 0, "DDS Security " + option + ": not a PEM X.509 certificate");
  return cert;
}

// SHA-256 of the certificate's DER encoding.
std::string Fingerprint(X509* cert) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (X509_digest(cert, EVP_sha256(), digest, &length) != 1) return "";
  return std::string(reinterpret_cast<const char*>(digest), length);
}

std::string FileUri(const std::string& path) {
  return "file://" + fs::absolute(path).lexically_normal().string();
}

}  // namespace

bool SecurityPluginsAvailable() {
#if HAVE_SECURITY
  return true;
#else
  return false;
#endif
}

SecurityOptions SecurityOptions::FromDirectory(const std::string& directory) {
  const fs::path dir(directory);
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw InputError(directory, 0, "DDS Security: credentials directory not found");
  SecurityOptions o;
  o.enabled = true;
  o.identity_ca = (dir / "ca_cert.pem").string();
  o.identity_certificate = (dir / "cert.pem").string();
  o.private_key = (dir / "key.pem").string();
  o.permissions_ca = o.identity_ca;
  o.governance = (dir / "governance.smime").string();
  o.permissions = (dir / "permissions.smime").string();
  o.Check();
  return o;
}

SecurityOptions SecurityOptions::FromEnvironment() {
  const char* dir = std::getenv("DYGSLAM_DDS_SECURITY_DIR");
  if (dir == nullptr || *dir == '\0') return SecurityOptions();
  return FromDirectory(dir);
}

void SecurityOptions::Check() const {
  if (!enabled) return;
  if (!SecurityPluginsAvailable()) {
    throw InvalidOptions(
        "invalid option DDS Security: this Fast DDS library was built without security");
  }
  RequireFile("identity_ca", identity_ca);
  RequireFile("identity_certificate", identity_certificate);
  RequireFile("private_key", private_key);
  RequireFile("permissions_ca", permissions_ca);
  RequireFile("governance", governance);
  RequireFile("permissions", permissions);
  // The identity chain, here and not in Fast DDS's handshake (which fails only on the remote
  // side, by stalling discovery without a message).
  const X509Ptr ca = ReadCertificate("identity_ca", identity_ca);
  const X509Ptr cert = ReadCertificate("identity_certificate", identity_certificate);
  EVP_PKEY* ca_key = X509_get0_pubkey(ca.get());
  if (ca_key == nullptr || X509_verify(cert.get(), ca_key) != 1) {
    throw InputError(identity_certificate, 0,
                     "DDS Security identity_certificate: not issued by the identity CA " +
                         identity_ca + " (the other participants could not authenticate it)");
  }
  if (X509_cmp_current_time(X509_get0_notBefore(cert.get())) >= 0)
    throw InputError(identity_certificate, 0,
                     "DDS Security identity_certificate: not valid yet (its notBefore is in the "
                     "future; is the clock right?)");
  if (X509_cmp_current_time(X509_get0_notAfter(cert.get())) <= 0)
    throw InputError(identity_certificate, 0, "DDS Security identity_certificate: expired");
  // The private key: readable as PEM, and the one of the certificate.
  std::unique_ptr<FILE, int (*)(FILE*)> key_file(std::fopen(private_key.c_str(), "r"),
                                                 &std::fclose);
  EVP_PKEY* key =
      key_file ? PEM_read_PrivateKey(key_file.get(), nullptr, NoPassphrase, nullptr) : nullptr;
  if (key == nullptr)
    throw InputError(private_key, 0,
                     "DDS Security private_key: not a PEM private key (an unencrypted one)");
  const int matches = X509_check_private_key(cert.get(), key);
  EVP_PKEY_free(key);
  if (matches != 1)
    throw InputError(private_key, 0,
                     "DDS Security private_key: not the key of the identity certificate " +
                         identity_certificate);
}

void CheckSameIdentityCa(const std::vector<std::pair<std::string, SecurityOptions>>& participants) {
  const std::pair<std::string, SecurityOptions>* reference = nullptr;
  std::string reference_print;
  for (const auto& participant : participants) {
    if (!participant.second.enabled) continue;
    const std::string print =
        Fingerprint(ReadCertificate("identity_ca", participant.second.identity_ca).get());
    if (reference == nullptr) {
      reference = &participant;
      reference_print = print;
    } else if (print != reference_print) {
      throw InputError(participant.second.identity_ca, 0,
                       "DDS Security: component '" + participant.first +
                           "' trusts another identity CA than component '" + reference->first +
                           "' (" + reference->second.identity_ca +
                           "): the two could not authenticate each other");
    }
  }
}

void ApplySecurity(const SecurityOptions& options,
                   eprosima::fastdds::dds::DomainParticipantQos* qos) {
  if (!options.enabled) return;
  options.Check();
  auto& props = qos->properties().properties();
  auto set = [&props](const std::string& name, const std::string& value) {
    for (auto& p : props) {
      if (p.name() == name) {
        p.value(value);
        return;
      }
    }
    props.emplace_back(name, value);
  };
  set("dds.sec.auth.plugin", "builtin.PKI-DH");
  set("dds.sec.auth.builtin.PKI-DH.identity_ca", FileUri(options.identity_ca));
  set("dds.sec.auth.builtin.PKI-DH.identity_certificate", FileUri(options.identity_certificate));
  set("dds.sec.auth.builtin.PKI-DH.private_key", FileUri(options.private_key));
  set("dds.sec.access.plugin", "builtin.Access-Permissions");
  set("dds.sec.access.builtin.Access-Permissions.permissions_ca", FileUri(options.permissions_ca));
  set("dds.sec.access.builtin.Access-Permissions.governance", FileUri(options.governance));
  set("dds.sec.access.builtin.Access-Permissions.permissions", FileUri(options.permissions));
  if (options.encrypt) set("dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC");
}

}  // namespace dygslam::dds
