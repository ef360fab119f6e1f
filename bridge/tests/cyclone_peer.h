// A stand-in ROS 2 node for the tests: Cyclone DDS (the DDS implementation behind
// rmw_cyclonedds) through its C API, with types compiled by idlc from the same ROS 2 IDL
// (bridge/idl) and the ROS 2 type names (pkg::msg::dds_::Type_) set on copies of the topic
// descriptors. PeerNetwork::kLoopback configures its domain on "lo" only with multicast forced on
// (the tests run inside run_in_netns.sh); PeerNetwork::kDefault is Cyclone's default
// configuration, as rmw_cyclonedds on a robot (it picks the host's non-loopback interface).
// The interface uses plain structs: the idlc headers share their paths with the fastddsgen ones
// ("sensor_msgs/msg/Image.h"), so only cyclone_peer.cc sees them.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace dygslam::testing {

struct PeerPose {
  int64_t stamp_ns = 0;
  std::string frame_id;
  double position[3] = {0, 0, 0};
  double orientation[4] = {0, 0, 0, 1};  // x y z w
};
struct PeerTransform {
  PeerPose pose;  // frame_id = parent
  std::string child_frame_id;
};
struct PeerPath {
  int64_t stamp_ns = 0;
  std::string frame_id;
  std::vector<PeerPose> poses;
};
struct PeerOdometry {
  PeerPose pose;
  std::string child_frame_id;
  double linear[3] = {0, 0, 0};
  double angular[3] = {0, 0, 0};
};
struct PeerBox {
  std::string class_id;
  double score = 0, center_x = 0, center_y = 0, size_x = 0, size_y = 0;
};
struct PeerDetections {
  int64_t stamp_ns = 0;
  std::string frame_id;
  std::vector<PeerBox> boxes;
};
struct PeerOctomap {
  int64_t stamp_ns = 0;
  std::string frame_id;
  bool binary = false;
  std::string id;
  double resolution = 0;
  std::vector<int8_t> data;
};

struct PeerCamera {
  int width = 640, height = 480;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::string model = "plumb_bob";
  std::vector<double> d = std::vector<double>(5, 0.0);
};

// ros_discovery_info as decoded with the Humble or Jazzy IDL (Gid 24 or 16 bytes).
struct PeerNodeInfo {
  std::string node_namespace, node_name;
  std::vector<std::vector<uint8_t>> readers, writers;  // Gids
};
struct PeerGraphInfo {
  std::vector<uint8_t> gid;
  std::vector<PeerNodeInfo> nodes;
};
// An endpoint / participant as Cyclone's own discovery sees it (built-in topics).
using PeerGuid = std::array<uint8_t, 16>;
struct PeerEndpoint {
  PeerGuid guid{}, participant_guid{};
  std::string topic, type;
  bool writer = false;
};
struct PeerParticipant {
  PeerGuid guid{};
  std::string user_data;
};

enum class PeerNetwork { kLoopback, kDefault };
enum class PeerDistro { kHumble, kJazzy };

// Subscribes (ROS 2 QoS: reliable; /tf_static and the map transient-local) to the bridge's
// outbound topics and keeps everything it receives.
struct RosOutputTopics {
  std::string pose = "rt/dygslam/pose", odom = "rt/dygslam/odom", path = "rt/dygslam/path",
              tf = "rt/tf", tf_static = "rt/tf_static", detections = "rt/dygslam/detections",
              octomap = "rt/dygslam/octomap_binary";
};

class CyclonePeer {
 public:
  explicit CyclonePeer(int domain, PeerNetwork network = PeerNetwork::kLoopback);
  ~CyclonePeer();
  CyclonePeer(const CyclonePeer&) = delete;
  CyclonePeer& operator=(const CyclonePeer&) = delete;

  // --- Outbound side of the bridge (this peer subscribes).
  void Subscribe(const RosOutputTopics& topics);
  // Number of matched bridge writers over all subscribed topics.
  int MatchedWriters() const;
  void Poll();  // takes every available sample into the vectors below
  std::vector<PeerPose> poses;
  std::vector<PeerOdometry> odometry;
  std::vector<PeerPath> paths;
  std::vector<PeerTransform> transforms;
  std::vector<PeerTransform> static_transforms;
  std::vector<PeerDetections> detections;
  std::vector<PeerOctomap> maps;

  // --- ROS 2 graph: subscribes to ros_discovery_info (reliable, transient local) with the IDL of
  // `distro`; Poll() appends what arrives.
  void SubscribeRosGraph(PeerDistro distro);
  std::vector<PeerGraphInfo> graph;
  // Remote and local endpoints / participants discovered so far (DCPSPublication,
  // DCPSSubscription, DCPSParticipant).
  std::vector<PeerEndpoint> DiscoveredEndpoints() const;
  std::vector<PeerParticipant> DiscoveredParticipants() const;

  // --- Inbound side (this peer is the camera driver): sensor-data QoS (best effort, keep-last 5).
  void Advertise(const std::string& color_topic, const std::string& depth_topic,
                 const std::string& info_topic);
  bool WaitForCameraReaders(std::chrono::milliseconds timeout) const;
  // Colour as "rgb8" (from BGR), depth as "16UC1" (millimetres) or "32FC1" (metres), plus
  // CameraInfo (camera.model, camera.d), all with the same stamp and frame_id. With
  // `color_encoding`, `bgr` is sent as it is under that encoding instead.
  void PublishFrame(int64_t stamp_ns, const cv::Mat& bgr, const cv::Mat& depth,
                    const PeerCamera& camera, const std::string& frame_id,
                    const std::string& color_encoding = "");

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dygslam::testing
