// The bridge's outbound half (pipeline -> ROS 2), used by RosBridge (ros2_bridge.h): per tracked
// frame (dygslam/camera_pose, handed over by PublishPose) geometry_msgs/PoseStamped,
// nav_msgs/Odometry and TF map -> camera_frame; nav_msgs/Path (online poses every path_every
// poses, replaced by the final refined trajectory of dygslam/trajectory);
// vision_msgs/Detection2DArray (dygslam/detections); octomap_msgs/Octomap (dygslam/map_update);
// /tf_static map -> world_frame once (transient-local). The listener callbacks queue jobs for one
// worker thread, so ROS writes never block the pipeline's listeners. Conversions:
// ros2_convert.h. No inbound topic here.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "bridge/ros2_bridge.h"
#include "bridge/ros2_endpoint.h"
#include "bridge/ros2_half.h"
#include "components/component_common.h"
#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "core/base/rigid3.h"
#include "core/base/types.h"
#include "dygslam_msg/CameraPosePubSubTypes.h"
#include "dygslam_msg/DetectionsPubSubTypes.h"
#include "dygslam_msg/MapUpdatePubSubTypes.h"
#include "dygslam_msg/TrajectoryPubSubTypes.h"
#include "geometry_msgs/msg/PoseStampedPubSubTypes.h"
#include "nav_msgs/msg/OdometryPubSubTypes.h"
#include "nav_msgs/msg/PathPubSubTypes.h"
#include "octomap_msgs/msg/OctomapPubSubTypes.h"
#include "tf2_msgs/msg/TFMessagePubSubTypes.h"
#include "vision_msgs/msg/Detection2DArrayPubSubTypes.h"

namespace dygslam::ros2 {

class RosOutbound : public RosHalf {
 public:
  // image_frame_id: frame_id of the incoming camera images ("" = none; detections then use
  // options.image_frame or the Detections message's own frame_id).
  RosOutbound(std::shared_ptr<dds::Participant> pipeline, std::shared_ptr<RosSession> ros,
              const RosBridgeOptions& options, std::function<std::string()> image_frame_id);
  ~RosOutbound() override;

  // The ROS writers, and /tf_static map -> world_frame.
  void CreateWriters() override;
  void StartThread() override;
  // The pipeline readers (trajectory, detections, map updates); the poses come through
  // PublishPose (the bridge's one CameraPose reader also drives the inbound back-pressure).
  void CreateReaders() override;
  void StopReaders() override;
  // Runs the jobs still queued, then ends the worker thread.
  void StopThread() override;
  // Lets reliable ROS readers receive the last path and map before the writers go away.
  void WaitForAcknowledgments(std::chrono::milliseconds timeout) override;

  // Queues the ROS pose, odometry, TF and path of one CameraPose (poses without has_pose: none).
  void PublishPose(msg::CameraPose&& pose);

  // A mapper's MapUpdate writer is matched (its last map is still to come at the end).
  bool map_writer_matched() const;
  // How many of the pipeline readers (trajectory, detections, map update) have a matched writer.
  int matched_pipeline_topics() const;
  // How many of the 7 ROS writers have matched at least one reader.
  int matched_ros_writers() const;
  // The outbound fields of the bridge statistics (the inbound ones stay 0).
  RosBridgeStats stats() const override;
  // GUIDs of the ROS writers (for the ROS 2 graph entry), in publication order.
  std::vector<eprosima::fastrtps::rtps::GUID_t> ros_writer_guids() const;

 private:
  void OnTrajectory(msg::Trajectory&& m);
  void OnDetections(msg::Detections&& m);
  void OnMapUpdate(msg::MapUpdate&& m);
  void Loop();

  std::shared_ptr<dds::Participant> participant_;  // pipeline topics
  std::shared_ptr<RosSession> ros_;
  const RosBridgeOptions options_;
  const Rigid3d map_from_world_;
  const std::function<std::string()> image_frame_id_;

  mutable std::mutex mutex_;  // guards stats_ and quit_
  RosBridgeStats stats_;
  bool quit_ = false;

  // Worker thread only.
  BlockingQueue<std::function<void()>> jobs_;
  std::vector<StampedPose> online_path_;  // world_from_cam
  std::optional<StampedPose> previous_map_from_cam_;
  bool final_path_ = false;

  std::unique_ptr<RosWriter<geometry_msgs::msg::PoseStampedPubSubType>> pose_writer_;
  std::unique_ptr<RosWriter<nav_msgs::msg::OdometryPubSubType>> odom_writer_;
  std::unique_ptr<RosWriter<nav_msgs::msg::PathPubSubType>> path_writer_;
  std::unique_ptr<RosWriter<tf2_msgs::msg::TFMessagePubSubType>> tf_writer_;
  std::unique_ptr<RosWriter<tf2_msgs::msg::TFMessagePubSubType>> tf_static_writer_;
  std::unique_ptr<RosWriter<vision_msgs::msg::Detection2DArrayPubSubType>> detections_writer_;
  std::unique_ptr<RosWriter<octomap_msgs::msg::OctomapPubSubType>> octomap_writer_;
  std::unique_ptr<dds::Reader<msg::TrajectoryPubSubType>> trajectory_reader_;
  std::unique_ptr<dds::Reader<msg::DetectionsPubSubType>> detections_reader_;
  std::unique_ptr<dds::Reader<msg::MapUpdatePubSubType>> map_reader_;
  std::thread thread_;
};

}  // namespace dygslam::ros2
