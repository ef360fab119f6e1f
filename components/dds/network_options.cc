#include "components/dds/network_options.h"

#include <arpa/inet.h>

#include <cerrno>
#include <cstdlib>

#include "core/base/error.h"

namespace dygslam::dds {

bool IsIpv4Address(const std::string& text) {
  in_addr parsed{};
  return inet_pton(AF_INET, text.c_str(), &parsed) == 1;
}

Endpoint ParseEndpoint(const std::string& text, const std::string& what) {
  const auto colon = text.rfind(':');
  const auto bad = [&](const std::string& why) {
    return InvalidOptions(what + ": expected ADDRESS:PORT (IPv4, port 1-65535), got '" + text +
                          "': " + why);
  };
  if (colon == std::string::npos) throw bad("no ':PORT'");
  Endpoint e;
  e.address = text.substr(0, colon);
  if (!IsIpv4Address(e.address)) throw bad("'" + e.address + "' is not an IPv4 address");
  const std::string port = text.substr(colon + 1);
  char* end = nullptr;
  errno = 0;
  const long value = port.empty() ? -1 : std::strtol(port.c_str(), &end, 10);
  if (port.empty() || *end != '\0' || errno != 0 || value < 1 || value > 65535) {
    throw bad("bad port '" + port + "'");
  }
  e.port = static_cast<uint16_t>(value);
  return e;
}

void NetworkOptions::Check() const {
  for (const std::string& address : interfaces) {
    if (!IsIpv4Address(address)) {
      throw InvalidOptions("invalid option DDS interface: '" + address +
                           "' is not an IPv4 address (give the address of this host's interface)");
    }
  }
  if (all_interfaces && !interfaces.empty()) {
    throw InvalidOptions(
        "invalid option DDS interface: a list of interfaces and 'all interfaces' exclude each "
        "other");
  }
  if (!discovery_server.empty()) ParseEndpoint(discovery_server, "discovery server");
}

}  // namespace dygslam::dds
