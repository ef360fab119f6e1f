// The ROS 2 graph announcement of the bridge: what rmw_fastrtps / rmw_cyclonedds publish so that
// `ros2 node list` shows a node and `ros2 topic info -v` names the node behind each endpoint.
//
// Every ROS 2 participant publishes one rmw_dds_common/msg/ParticipantEntitiesInfo on the DDS
// topic "ros_discovery_info" (no "rt/" prefix; reliable, transient local, keep-last 1):
//
//   ParticipantEntitiesInfo: Gid gid; NodeEntitiesInfo[] node_entities_info_seq
//   NodeEntitiesInfo:        string<=256 node_namespace; string<=256 node_name;
//                            Gid[] reader_gid_seq; Gid[] writer_gid_seq
//   Gid:                     char[24] data (Humble), char[16] data (Iron, Jazzy)
//
// A GID is the DDS GUID (12-byte GUID prefix + 4-byte entity id), zero-padded to the Gid size.
// The participant also carries USER_DATA "enclave=/;" (the ROS 2 security enclave).
//
// This file has no DDS header: encoding only (XCDR1 = plain CDR, little endian, with the 4-byte
// encapsulation header), used by the Fast DDS type support in ros2_graph_type.h.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace dygslam::ros2 {

enum class RosDistro { kHumble, kJazzy };

// "humble" | "jazzy" (also "iron", "kilted" and "rolling": 16-byte Gid as Jazzy). Throws
// InvalidOptions naming `option` otherwise.
RosDistro ParseRosDistro(const std::string& text, const std::string& option);
const char* RosDistroName(RosDistro distro);
// Bytes of rmw_dds_common/msg/Gid on the wire: 24 (Humble), 16 (Iron and later).
size_t GidSize(RosDistro distro);

// GUID prefix (12 bytes) + entity id (4 bytes).
using Guid = std::array<uint8_t, 16>;

struct RosNodeEntities {
  std::string node_namespace = "/";
  std::string node_name;
  std::vector<Guid> readers, writers;
};

struct RosParticipantEntities {
  Guid participant{};
  std::vector<RosNodeEntities> nodes;
};

inline constexpr const char* kRosDiscoveryTopic = "ros_discovery_info";
inline constexpr const char* kParticipantEntitiesInfoType =
    "rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_";
inline constexpr const char* kRosEnclaveUserData = "enclave=/;";

// Checks a ROS 2 node name ([A-Za-z_][A-Za-z0-9_]*, at most 255 characters) and namespace ("/",
// or "/" + tokens of [A-Za-z0-9_] separated by single '/', no trailing '/', a token not starting
// with a digit). Throws InvalidOptions naming `option`.
void CheckNodeName(const std::string& name, const std::string& option);
void CheckNodeNamespace(const std::string& ns, const std::string& option);

// The serialized sample (encapsulation header CDR_LE + body).
std::vector<uint8_t> EncodeParticipantEntitiesInfo(const RosParticipantEntities& info,
                                                   RosDistro distro);

}  // namespace dygslam::ros2
