#include "components/dds/network_options.h"

#include <arpa/inet.h>
#include <ifaddrs.h>
#include <netinet/in.h>

#include <cerrno>
#include <cstdlib>
#include <set>

#include "core/base/echo.h"
#include "core/base/error.h"

namespace dygslam::dds {

bool IsIpv4Address(const std::string& text) {
  in_addr parsed{};
  return inet_pton(AF_INET, text.c_str(), &parsed) == 1;
}

Endpoint ParseEndpoint(const std::string& text, const std::string& what) {
  const auto colon = text.rfind(':');
  const auto bad = [&](const std::string& why) {
    return InvalidOptions(what + ": expected ADDRESS:PORT (IPv4, port 1-65535), got '" +
                          EchoValue(text) + "': " + why);
  };
  if (colon == std::string::npos) throw bad("no ':PORT'");
  Endpoint e;
  e.address = text.substr(0, colon);
  if (!IsIpv4Address(e.address)) throw bad("'" + EchoValue(e.address) + "' is not an IPv4 address");
  const std::string port = text.substr(colon + 1);
  char* end = nullptr;
  errno = 0;
  const long value = port.empty() ? -1 : std::strtol(port.c_str(), &end, 10);
  if (port.empty() || *end != '\0' || errno != 0 || value < 1 || value > 65535) {
    throw bad("bad port '" + EchoValue(port) + "'");
  }
  e.port = static_cast<uint16_t>(value);
  return e;
}

namespace {

// This host's IPv4 interface addresses (empty if they cannot be listed).
std::set<std::string> HostIpv4Addresses() {
  std::set<std::string> out;
  ifaddrs* list = nullptr;
  if (getifaddrs(&list) != 0) return out;
  for (ifaddrs* a = list; a != nullptr; a = a->ifa_next) {
    if (a->ifa_addr == nullptr || a->ifa_addr->sa_family != AF_INET) continue;
    char text[INET_ADDRSTRLEN] = {0};
    const auto* in = reinterpret_cast<const sockaddr_in*>(a->ifa_addr);
    if (inet_ntop(AF_INET, &in->sin_addr, text, sizeof(text)) != nullptr) out.insert(text);
  }
  freeifaddrs(list);
  return out;
}

}  // namespace

void NetworkOptions::Check() const {
  for (const std::string& address : interfaces) {
    if (!IsIpv4Address(address)) {
      throw InvalidOptions("invalid option DDS interface: '" + address +
                           "' is not an IPv4 address (give the address of this host's interface)");
    }
  }
  // An address that is not this host's: Fast DDS filters it out of the whitelist and the
  // participant runs with no usable interface ("playing anyway"); refuse it instead.
  if (!interfaces.empty()) {
    const std::set<std::string> host = HostIpv4Addresses();
    for (const std::string& address : interfaces) {
      if (host.empty() || host.count(address) > 0) continue;
      std::string known;
      for (const std::string& h : host) known += (known.empty() ? "" : ", ") + h;
      throw InvalidOptions("--dds-interface: " + address +
                           " is not an address of this host's interfaces (" + known + ")");
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
