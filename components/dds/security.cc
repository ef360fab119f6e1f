#include "components/dds/security.h"

#include <fastrtps/config.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

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
