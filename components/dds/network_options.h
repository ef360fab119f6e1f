// Where a component's DDS traffic goes. The default keeps everything on this machine (shared
// memory + UDP on 127.0.0.1). To put components on several hosts (the detector or the mapper on
// another machine), give the interfaces' IPv4 addresses; networks without multicast use a
// discovery server (`dygslam discovery-server`) instead of multicast discovery. No DDS types here
// (PipelineOptions carries it); components/dds/participant.cc applies it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace dygslam::dds {

struct NetworkOptions {
  // IPv4 addresses of this host's interfaces that UDP may use (a whitelist). Empty: 127.0.0.1
  // only, nothing leaves the machine.
  std::vector<std::string> interfaces;
  // UDP on every interface of this host, no whitelist (as ROS 2 nodes do; the ROS 2 bridge's
  // ROS-side participant). Excludes `interfaces`.
  bool all_interfaces = false;
  // Fast DDS's shared-memory transport (same host only). Off for a run that must show the
  // network path, or where /dev/shm is not shared (containers without `ipc: host`).
  bool shared_memory = true;
  // "ADDRESS:PORT" of a discovery server: discovery goes through it (no multicast needed).
  // Empty: the standard multicast discovery (SPDP).
  std::string discovery_server;
  void Check() const;  // throws InvalidOptions naming the bad field
};

// "a.b.c.d:port" -> address, port; throws InvalidOptions naming `what` otherwise.
struct Endpoint {
  std::string address;
  uint16_t port = 0;
};
Endpoint ParseEndpoint(const std::string& text, const std::string& what);
// True for a dotted-quad IPv4 address.
bool IsIpv4Address(const std::string& text);

}  // namespace dygslam::dds
