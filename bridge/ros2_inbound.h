// The bridge's inbound half (ROS 2 camera -> pipeline), used by RosBridge (ros2_bridge.h):
// colour + aligned depth sensor_msgs/Image and sensor_msgs/CameraInfo on the ROS side, paired by
// stamp (RgbdSynchronizer), rectified when the camera model asks for it, and forwarded as
// dygslam/rgbd_frame (seq 0, 1, ...) with the player's back-pressure: frame k goes out once slam
// acknowledged frame k - window (Acknowledge), the first one once the frame consumers announced
// READY (ComponentReady) and matched the frame topic. END_OF_STREAM on EndInput() or after
// end_of_stream_idle_s without frames. Conversions: ros2_convert.h. No outbound topic here.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "bridge/rgbd_sync.h"
#include "bridge/ros2_bridge.h"
#include "bridge/ros2_convert.h"
#include "bridge/ros2_endpoint.h"
#include "bridge/ros2_half.h"
#include "components/convert.h"
#include "components/dds/endpoint.h"
#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "dygslam_msg/RgbdFramePubSubTypes.h"
#include "dygslam_msg/StreamStatusPubSubTypes.h"
#include "sensor_msgs/msg/CameraInfoPubSubTypes.h"
#include "sensor_msgs/msg/ImagePubSubTypes.h"

namespace dygslam::ros2 {

class RosInbound : public RosHalf {
 public:
  RosInbound(std::shared_ptr<dds::Participant> pipeline, std::shared_ptr<RosSession> ros,
             const RosBridgeOptions& options);
  ~RosInbound() override;

  // The pipeline writers (frames, status) and the STARTED announcement of the frame writer.
  void CreateWriters() override;
  // The forwarding thread.
  void StartThread() override;
  // The ROS 2 readers (colour, depth, camera info); last, their callbacks need the rest.
  void CreateReaders() override;
  // Readers first (no callback after this returns), then the thread.
  void StopReaders() override;
  void StopThread() override;
  // Lets reliable pipeline readers receive the last status (END_OF_STREAM).
  void WaitForAcknowledgments(std::chrono::milliseconds timeout) override;

  // slam acknowledged frame `seq` (its CameraPose): opens the back-pressure window.
  void Acknowledge(uint64_t seq);
  // A component announced READY (StreamStatus source name).
  void ComponentReady(const std::string& name);
  // Forwards the frames still pending, then publishes END_OF_STREAM (once).
  void EndInput();
  // Waits up to `timeout` for END_OF_STREAM to be sent; true if it was.
  bool WaitForEndOfStream(std::chrono::milliseconds timeout);

  // frame_id of the newest colour image ("" before the first).
  std::string image_frame_id() const;
  // The inbound fields of the bridge statistics (the outbound ones stay 0).
  RosBridgeStats stats() const override;
  // GUIDs of the ROS readers (for the ROS 2 graph entry), in subscription order.
  std::vector<eprosima::fastrtps::rtps::GUID_t> ros_reader_guids() const;

 private:
  using Clock = std::chrono::steady_clock;
  void OnImage(sensor_msgs::msg::Image&& image, bool is_color);
  void OnCameraInfo(sensor_msgs::msg::CameraInfo&& info);
  // A ROS reader's middleware counts grew (`topic`: the ROS topic name).
  void OnLoss(const std::string& topic, const dds::ReaderLosses& losses);
  void AddFrameLocked(RgbdFrame&& pair);
  void RejectLocked(const std::string& reason);
  std::string MissingComponentsLocked() const;
  int ExpectedFrameReaders() const;
  bool ConsumersReadyLocked();
  void Loop();

  std::shared_ptr<dds::Participant> participant_;  // pipeline topics
  std::shared_ptr<RosSession> ros_;
  const RosBridgeOptions options_;

  mutable std::mutex mutex_;  // guards everything below except the endpoints
  std::condition_variable cv_;
  RosBridgeStats stats_;
  bool quit_ = false;
  RgbdSynchronizer sync_;
  std::optional<RosCamera> camera_;
  std::unique_ptr<ImageRectifier> rectifier_;  // for camera_
  std::string image_frame_id_;
  std::deque<RgbdFrameData> pending_;
  uint64_t next_seq_ = 0;
  int64_t acked_through_ = -1;  // highest frame seq slam acknowledged
  std::optional<Clock::time_point> head_wait_start_;
  Clock::time_point last_frame_time_ = Clock::now();
  bool end_requested_ = false;
  std::set<std::string> started_;  // READY announcements seen (component names)
  bool consumers_ready_ = false;   // wait_for_components announced (or timed out)
  Clock::time_point consumers_deadline_;

  std::unique_ptr<dds::Writer<msg::RgbdFramePubSubType>> frame_writer_;
  std::unique_ptr<dds::Writer<msg::StreamStatusPubSubType>> status_writer_;
  std::unique_ptr<RosReader<sensor_msgs::msg::ImagePubSubType>> color_reader_, depth_reader_;
  std::unique_ptr<RosReader<sensor_msgs::msg::CameraInfoPubSubType>> info_reader_;
  std::thread thread_;
};

}  // namespace dygslam::ros2
