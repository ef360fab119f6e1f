// The ROS 2 bridge component: speaks ROS 2's wire conventions (topics rt/<name>, type names
// pkg::msg::dds_::Type_, keyless types, XCDR1, rclcpp QoS profiles; see ros2_qos.h) on the same
// Fast DDS domain as the pipeline, so ROS 2 nodes (camera drivers, rviz, Nav2) and dygslam talk
// directly, without ROS 2 installed on the dygslam side.
//
// Inbound (ROS 2 camera -> pipeline): colour + aligned depth sensor_msgs/Image and
// sensor_msgs/CameraInfo, paired by stamp (RgbdSynchronizer), depth 16UC1 millimetres (scaled by
// depth_unit) or 32FC1 metres -> dygslam/rgbd_frame (seq 0, 1, ...), so slam consumes them as if
// from the player. Back-pressure like the player's: frame k is forwarded only once slam has
// acknowledged (CameraPose) frame k - window; synchronised frames waiting beyond
// max_pending_frames are dropped oldest first (a live camera: latency stays bounded). EndInput()
// (or end_of_stream_idle_s without frames, or the bridge stopping with end_of_stream_on_stop)
// publishes END_OF_STREAM so slam finishes and publishes its final trajectory.
//
// Outbound (pipeline -> ROS 2): per tracked frame (dygslam/camera_pose) geometry_msgs/PoseStamped,
// nav_msgs/Odometry and TF map -> camera_frame; nav_msgs/Path (online poses every path_every
// poses, replaced by the final refined trajectory from dygslam/trajectory);
// vision_msgs/Detection2DArray (dygslam/detections, in image_frame); octomap_msgs/Octomap
// (dygslam/map_update, binary, in world_frame); /tf_static map -> world_frame once
// (transient-local). map_from_world = MapFromWorld(ros_axes).
//
// Two participants: the pipeline's topics stay on the pipeline participant (shared memory +
// 127.0.0.1 by default, the pipeline's partition), the ROS 2 topics live on a ROS participant
// with the ROS network profile (RosParticipantOptions: UDP on every interface of the host, as
// ROS 2 nodes, so a same-host peer that announces its LAN address -- rmw_cyclonedds with default
// settings -- is reachable). The ROS participant also publishes the bridge's ROS 2 graph entry
// (ros_discovery_info, ros2_graph.h): `ros2 node list` shows node_namespace/node_name.
//
// Code: the inbound half is RosInbound (ros2_inbound.h), the outbound half RosOutbound
// (ros2_outbound.h); RosBridge (ros2_bridge.cc) holds both and the readers they share; the
// message conversions are in ros2_convert.h.
//
// DDS partitions: the pipeline side (dygslam/* topics) uses the participant's partition
// (dds::ParticipantOptions::partition = the pipeline's, e.g. `dygslam component ... --partition
// NAME`), the ROS 2 side always the default partition (ROS 2 uses none).
#pragma once

#include <cstddef>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "bridge/ros2_graph.h"
#include "components/component_common.h"
#include "components/dds/participant.h"

namespace dygslam {

namespace ros2 {

struct RosBridgeOptions {
  // --- Inbound.
  bool inbound = true;
  std::string color_topic = "/camera/camera/color/image_raw";
  std::string depth_topic = "/camera/camera/aligned_depth_to_color/image_raw";
  std::string camera_info_topic = "/camera/camera/color/camera_info";
  double depth_unit = 0.001;  // metres per 16UC1 count (ROS convention: millimetres)
  double max_stamp_difference_s = 0.02;
  int window = 2;                   // frames in flight to slam (0 = no back-pressure)
  size_t max_pending_frames = 2;    // synchronised frames waiting for the window
  double ack_timeout_s = 5.0;       // forward anyway after waiting this long for slam
  double end_of_stream_idle_s = 0;  // END_OF_STREAM after this long without frames (0 = never)
  bool end_of_stream_on_stop = false;
  // The first frame is forwarded only once these components announced STARTED (StreamStatus,
  // source = name; as the player waits for them) and the frame topic is matched by as many
  // readers as there are frame consumers ("slam", "detector") among them: the frame topic is
  // volatile, so a frame sent before then is lost for a component (and slam in --deterministic
  // mode would wait forever for its detections). At most wait_for_components_s, then forwarding
  // starts anyway (logged). Meanwhile frames queue up to max_pending_frames (oldest dropped).
  std::vector<std::string> wait_for_components = {"slam"};
  double wait_for_components_s = 60.0;

  // --- Outbound.
  bool outbound = true;
  std::string pose_topic = "/dygslam/pose";
  std::string odom_topic = "/dygslam/odom";
  std::string path_topic = "/dygslam/path";
  std::string tf_topic = "/tf";
  std::string tf_static_topic = "/tf_static";
  std::string detections_topic = "/dygslam/detections";
  std::string octomap_topic = "/dygslam/octomap_binary";
  std::string map_frame = "map";
  std::string world_frame = "dygslam_world";    // the SLAM world (first camera, optical axes)
  std::string camera_frame = "dygslam_camera";  // TF child (optical axes)
  // Frame of detections; "" = the frame_id of the incoming images (else "camera").
  std::string image_frame;
  bool ros_axes = true;  // map = REP 103 axes (x forward, y left, z up); false: map = world
  bool publish_tf = true;
  int path_every = 10;  // online path every N tracked poses (0 = only the final trajectory)

  // --- ROS 2 graph (ros_discovery_info).
  bool announce_node = true;
  std::string node_name = "dygslam";
  std::string node_namespace = "/";
  RosDistro ros_distro = RosDistro::kJazzy;  // Gid size of ros_discovery_info

  void Check() const;
  // Topic defaults of common ROS 2 camera drivers: "realsense" (realsense2_camera >= 4.54:
  // /camera/camera/...), "realsense-legacy" (/camera/...), "azure-kinect" (Azure_Kinect_ROS_Driver:
  // /rgb/image_raw, /depth_to_rgb/image_raw, /rgb/camera_info), "kinect" (kinect_ros2:
  // /image_raw, /depth/image_raw, /camera_info). Throws InvalidOptions for an unknown name.
  void ApplyCameraPreset(const std::string& preset);
};

struct RosBridgeStats {
  // Inbound.
  size_t color_received = 0, depth_received = 0, camera_info_received = 0;
  size_t frames_forwarded = 0;
  size_t dropped_unsynchronized = 0;  // colour / depth without a partner
  size_t dropped_no_camera_info = 0;
  size_t dropped_pending = 0;  // max_pending_frames exceeded
  size_t ack_timeouts = 0;
  size_t bad_samples = 0;  // rejected ROS messages (sum of `rejected`)
  // Rejected ROS messages by kind (the field at fault, e.g. "<topic>.encoding"); the first of
  // each kind is logged with the reason.
  std::map<std::string, size_t> rejected;
  // Samples the ROS readers never received (lost in transport, e.g. an image whose fragments
  // overflowed the socket buffers, or rejected by the reader's resource limits), in total and
  // by ROS topic; each loss is logged (the first few, then every 100th).
  size_t samples_lost = 0;
  std::map<std::string, size_t> lost_by_topic;
  bool end_of_stream_sent = false;
  // Outbound.
  size_t poses = 0, paths = 0, transforms = 0, detections = 0, maps = 0;
  size_t bad_pipeline_samples = 0;
};

// The ROS network profile of the bridge's ROS participant: UDPv4 on every interface (no
// whitelist; 4 MiB socket buffers), shared memory (16 MiB segment) unless `shared_memory` is
// false (containers without a shared /dev/shm), USER_DATA "enclave=/;". With
// FASTRTPS_DEFAULT_PROFILES_FILE set, the XML's participant profile "dygslam_ros" (or its default
// profile) is used instead.
dds::ParticipantOptions RosParticipantOptions(int domain_id, bool shared_memory = true);

class RosBridge {
 public:
  // `ros` carries the ROS 2 topics, `pipeline` the dygslam/* topics (may be the same).
  RosBridge(std::shared_ptr<dds::Participant> pipeline, std::shared_ptr<dds::Participant> ros,
            const RosBridgeOptions& options);
  // One participant for both sides.
  RosBridge(std::shared_ptr<dds::Participant> participant, const RosBridgeOptions& options);
  ~RosBridge();
  RosBridge(const RosBridge&) = delete;
  RosBridge& operator=(const RosBridge&) = delete;

  // Forwards the frames still pending, then publishes END_OF_STREAM (once).
  void EndInput();
  // True once slam reported COMPONENT_DONE (after END_OF_STREAM).
  bool slam_done() const;
  // slam is done and the mapper (if one is running) has published its last map.
  bool outputs_done() const;
  // How many of the 7 outbound ROS writers (pose, odom, path, tf, tf_static, detections,
  // octomap) have matched at least one reader (0 without outbound). A ROS topic is volatile
  // (except tf_static / octomap): a sample written before its reader matched is not delivered.
  int matched_ros_writers() const;
  // How many of the pipeline topics the outbound half reads (camera pose, trajectory, detections,
  // map update) have a matched writer (0 without outbound). The detections writer goes away
  // with the detector at the end of the stream: a bridge that discovers the pipeline later gets
  // none of them.
  int matched_pipeline_topics() const;
  RosBridgeStats stats() const;
  // What the bridge announced on ros_discovery_info (empty nodes if announce_node is false).
  RosParticipantEntities graph_entry() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Runs the bridge until `stop` (or, after END_OF_STREAM, until slam is done and the final
// outputs were republished). Returns its statistics.
RosBridgeStats RunBridge(std::shared_ptr<dds::Participant> pipeline,
                         std::shared_ptr<dds::Participant> ros, const RosBridgeOptions& options,
                         const StopFlagPtr& stop);

}  // namespace ros2
}  // namespace dygslam
