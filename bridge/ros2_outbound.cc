#include "bridge/ros2_outbound.h"

#include <utility>

#include "bridge/ros2_convert.h"
#include "components/convert.h"
#include "core/base/error.h"
#include "core/base/log.h"
#include "core/base/thread_setup.h"

namespace dygslam::ros2 {

RosOutbound::RosOutbound(std::shared_ptr<dds::Participant> pipeline,
                         std::shared_ptr<RosSession> ros, const RosBridgeOptions& options,
                         std::function<std::string()> image_frame_id)
    : participant_(std::move(pipeline)),
      ros_(std::move(ros)),
      options_(options),
      map_from_world_(MapFromWorld(options.ros_axes)),
      image_frame_id_(std::move(image_frame_id)) {}

RosOutbound::~RosOutbound() {
  StopReaders();
  StopThread();
}

void RosOutbound::CreateWriters() {
  const auto& o = options_;
  const RosQos reliable = RosQos::Default();
  pose_writer_ = std::make_unique<RosWriter<geometry_msgs::msg::PoseStampedPubSubType>>(
      ros_, DdsTopicName(o.pose_topic, "pose_topic"), reliable);
  odom_writer_ = std::make_unique<RosWriter<nav_msgs::msg::OdometryPubSubType>>(
      ros_, DdsTopicName(o.odom_topic, "odom_topic"), reliable);
  path_writer_ = std::make_unique<RosWriter<nav_msgs::msg::PathPubSubType>>(
      ros_, DdsTopicName(o.path_topic, "path_topic"), reliable);
  tf_writer_ = std::make_unique<RosWriter<tf2_msgs::msg::TFMessagePubSubType>>(
      ros_, DdsTopicName(o.tf_topic, "tf_topic"), RosQos{true, false, 100});
  tf_static_writer_ = std::make_unique<RosWriter<tf2_msgs::msg::TFMessagePubSubType>>(
      ros_, DdsTopicName(o.tf_static_topic, "tf_static_topic"), RosQos::TransientLocal());
  detections_writer_ = std::make_unique<RosWriter<vision_msgs::msg::Detection2DArrayPubSubType>>(
      ros_, DdsTopicName(o.detections_topic, "detections_topic"), reliable);
  octomap_writer_ = std::make_unique<RosWriter<octomap_msgs::msg::OctomapPubSubType>>(
      ros_, DdsTopicName(o.octomap_topic, "octomap_topic"), RosQos::TransientLocal());
  // The static map -> SLAM world transform (the octree is expressed in the world frame).
  tf2_msgs::msg::TFMessage tf_static;
  tf_static.transforms().push_back(
      TransformToRos(map_from_world_, Timestamp(), o.map_frame, o.world_frame));
  tf_static_writer_->Write(tf_static);
}

void RosOutbound::StartThread() {
  thread_ = std::thread([this] {
    SetCurrentThreadName("ros2 out");
    Loop();
  });
}

void RosOutbound::CreateReaders() {
  trajectory_reader_ = std::make_unique<dds::Reader<msg::TrajectoryPubSubType>>(
      participant_, dds::topics::kTrajectory, dds::TopicKind::kTrajectory,
      [this](msg::Trajectory&& m) { OnTrajectory(std::move(m)); });
  detections_reader_ = std::make_unique<dds::Reader<msg::DetectionsPubSubType>>(
      participant_, dds::topics::kDetections, dds::TopicKind::kDetections,
      [this](msg::Detections&& m) { OnDetections(std::move(m)); });
  map_reader_ = std::make_unique<dds::Reader<msg::MapUpdatePubSubType>>(
      participant_, dds::topics::kMapUpdate, dds::TopicKind::kMapUpdate,
      [this](msg::MapUpdate&& m) { OnMapUpdate(std::move(m)); });
}

void RosOutbound::StopReaders() {
  trajectory_reader_.reset();
  detections_reader_.reset();
  map_reader_.reset();
}

void RosOutbound::StopThread() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    quit_ = true;
  }
  if (thread_.joinable()) thread_.join();
}

void RosOutbound::WaitForAcknowledgments(std::chrono::milliseconds timeout) {
  if (path_writer_) path_writer_->WaitForAcknowledgments(timeout);
  if (octomap_writer_) octomap_writer_->WaitForAcknowledgments(timeout);
}

bool RosOutbound::map_writer_matched() const { return map_reader_ && map_reader_->matched() > 0; }

int RosOutbound::matched_pipeline_topics() const {
  int n = 0;
  if (trajectory_reader_ && trajectory_reader_->matched() > 0) ++n;
  if (detections_reader_ && detections_reader_->matched() > 0) ++n;
  if (map_reader_ && map_reader_->matched() > 0) ++n;
  return n;
}

int RosOutbound::matched_ros_writers() const {
  int n = 0;
  if (pose_writer_ && pose_writer_->matched() > 0) ++n;
  if (odom_writer_ && odom_writer_->matched() > 0) ++n;
  if (path_writer_ && path_writer_->matched() > 0) ++n;
  if (tf_writer_ && tf_writer_->matched() > 0) ++n;
  if (tf_static_writer_ && tf_static_writer_->matched() > 0) ++n;
  if (detections_writer_ && detections_writer_->matched() > 0) ++n;
  if (octomap_writer_ && octomap_writer_->matched() > 0) ++n;
  return n;
}

RosBridgeStats RosOutbound::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

std::vector<eprosima::fastrtps::rtps::GUID_t> RosOutbound::ros_writer_guids() const {
  std::vector<eprosima::fastrtps::rtps::GUID_t> guids;
  if (pose_writer_) guids.push_back(pose_writer_->rtps_guid());
  if (odom_writer_) guids.push_back(odom_writer_->rtps_guid());
  if (path_writer_) guids.push_back(path_writer_->rtps_guid());
  for (const auto* w : {tf_writer_.get(), tf_static_writer_.get()}) {
    if (w != nullptr) guids.push_back(w->rtps_guid());
  }
  if (detections_writer_) guids.push_back(detections_writer_->rtps_guid());
  if (octomap_writer_) guids.push_back(octomap_writer_->rtps_guid());
  return guids;
}

// ---- Listener callbacks queue jobs for the worker thread.

void RosOutbound::PublishPose(msg::CameraPose&& m) {
  if (!m.has_pose()) return;
  jobs_.Push([this, m = std::move(m)] {
    const Timestamp stamp = TimeFromMsg(m.header().stamp(), "CameraPose.header.stamp");
    const Rigid3d world_from_cam = PoseFromMsg(m.world_from_cam(), "CameraPose.world_from_cam");
    const Rigid3d map_from_cam = map_from_world_ * world_from_cam;
    pose_writer_->Write(PoseStampedToRos(map_from_cam, stamp, options_.map_frame));
    const StampedPose current{stamp, map_from_cam};
    odom_writer_->Write(
        OdometryToRos(current, previous_map_from_cam_, options_.map_frame, options_.camera_frame));
    previous_map_from_cam_ = current;
    size_t transforms = 0;
    if (options_.publish_tf) {
      tf2_msgs::msg::TFMessage tf;
      tf.transforms().push_back(
          TransformToRos(map_from_cam, stamp, options_.map_frame, options_.camera_frame));
      tf_writer_->Write(tf);
      transforms = 1;
    }
    bool path = false;
    if (!final_path_) {
      online_path_.push_back({stamp, world_from_cam});
      if (options_.path_every > 0 && online_path_.size() % options_.path_every == 0) {
        path_writer_->Write(PathToRos(online_path_, map_from_world_, stamp, options_.map_frame));
        path = true;
      }
    }
    std::lock_guard<std::mutex> lock(mutex_);
    ++stats_.poses;
    stats_.transforms += transforms;
    if (path) ++stats_.paths;
  });
}

void RosOutbound::OnTrajectory(msg::Trajectory&& m) {
  if (m.keyframes_only()) return;
  jobs_.Push([this, m = std::move(m)] {
    const std::vector<StampedPose> poses = TrajectoryFromMsg(m);
    const Timestamp stamp = poses.empty() ? Timestamp() : poses.back().stamp;
    path_writer_->Write(PathToRos(poses, map_from_world_, stamp, options_.map_frame));
    final_path_ = true;
    std::lock_guard<std::mutex> lock(mutex_);
    ++stats_.paths;
  });
}

void RosOutbound::OnDetections(msg::Detections&& m) {
  jobs_.Push([this, m = std::move(m)] {
    const Timestamp stamp = TimeFromMsg(m.header().stamp(), "Detections.header.stamp");
    const std::vector<Detection> dets = DetectionsFromMsg(m);
    std::string frame = options_.image_frame;
    if (frame.empty()) frame = image_frame_id_();
    if (frame.empty()) frame = m.header().frame_id().empty() ? "camera" : m.header().frame_id();
    detections_writer_->Write(DetectionsToRos(dets, stamp, frame));
    std::lock_guard<std::mutex> lock(mutex_);
    ++stats_.detections;
  });
}

void RosOutbound::OnMapUpdate(msg::MapUpdate&& m) {
  jobs_.Push([this, m = std::move(m)] {
    const Timestamp stamp = TimeFromMsg(m.header().stamp(), "MapUpdate.header.stamp");
    octomap_writer_->Write(OctomapToRos(m.octree_bt(), stamp, options_.world_frame));
    std::lock_guard<std::mutex> lock(mutex_);
    ++stats_.maps;
  });
}

void RosOutbound::Loop() {
  while (true) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (quit_ && jobs_.size() == 0) return;
    }
    auto job = jobs_.Pop(std::chrono::milliseconds(20));
    if (!job) continue;
    try {
      (*job)();
    } catch (const InputError& e) {
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.bad_pipeline_samples;
      LOG_WARNING << "ros2 bridge: dropped pipeline sample: " << e.what();
    }
  }
}

}  // namespace dygslam::ros2
