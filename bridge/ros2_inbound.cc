#include "bridge/ros2_inbound.h"

#include <utility>

#include "components/dds/qos.h"
#include "core/base/error.h"
#include "core/base/log.h"
#include "core/base/thread_setup.h"

namespace dygslam::ros2 {

namespace {

// Logs the first few occurrences, then every 100th.
bool ShouldLog(size_t count) { return count <= 5 || count % 100 == 0; }

msg::StreamStatus MakeStatus(StreamEvent event, uint64_t num_frames, uint64_t seq) {
  msg::StreamStatus s;
  s.kind(static_cast<uint8_t>(event));
  s.source("ros2_bridge");
  s.num_frames(num_frames);
  s.header().seq(seq);
  return s;
}

}  // namespace

RosInbound::RosInbound(std::shared_ptr<dds::Participant> pipeline, std::shared_ptr<RosSession> ros,
                       const RosBridgeOptions& options)
    : participant_(std::move(pipeline)),
      ros_(std::move(ros)),
      options_(options),
      sync_(RgbdSyncOptions{options.max_stamp_difference_s, 16}),
      consumers_deadline_(Clock::now() + std::chrono::milliseconds(static_cast<int64_t>(
                                             options.wait_for_components_s * 1000))) {}

RosInbound::~RosInbound() {
  StopReaders();
  StopThread();
}

void RosInbound::CreateWriters() {
  frame_writer_ = std::make_unique<dds::Writer<msg::RgbdFramePubSubType>>(
      participant_, dds::topics::kRgbdFrame, dds::TopicKind::kRgbdFrame);
  status_writer_ = std::make_unique<dds::Writer<msg::StreamStatusPubSubType>>(
      participant_, dds::topics::kStreamStatus, dds::TopicKind::kStreamStatus);
  // slam takes frames only from announced writers (components/protocol.h).
  status_writer_->Write(ToMsg(ComponentStatus::Started(
      ComponentKind::kRos2Bridge, {{DataTopic::kFrames, frame_writer_->guid()}})));
}

void RosInbound::StartThread() {
  thread_ = std::thread([this] {
    SetCurrentThreadName("ros2 in");
    Loop();
  });
}

void RosInbound::CreateReaders() {
  const RosQos sensor = RosQos::SensorData();
  const auto losses_on = [this](const std::string& topic) {
    return [this, topic](const dds::ReaderLosses& l) { OnLoss(topic, l); };
  };
  color_reader_ = std::make_unique<RosReader<sensor_msgs::msg::ImagePubSubType>>(
      ros_, DdsTopicName(options_.color_topic, "color_topic"), sensor,
      [this](sensor_msgs::msg::Image&& m) { OnImage(std::move(m), true); },
      losses_on(options_.color_topic));
  depth_reader_ = std::make_unique<RosReader<sensor_msgs::msg::ImagePubSubType>>(
      ros_, DdsTopicName(options_.depth_topic, "depth_topic"), sensor,
      [this](sensor_msgs::msg::Image&& m) { OnImage(std::move(m), false); },
      losses_on(options_.depth_topic));
  info_reader_ = std::make_unique<RosReader<sensor_msgs::msg::CameraInfoPubSubType>>(
      ros_, DdsTopicName(options_.camera_info_topic, "camera_info_topic"), sensor,
      [this](sensor_msgs::msg::CameraInfo&& m) { OnCameraInfo(std::move(m)); },
      losses_on(options_.camera_info_topic));
}

void RosInbound::StopReaders() {
  color_reader_.reset();
  depth_reader_.reset();
  info_reader_.reset();
}

void RosInbound::StopThread() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    quit_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void RosInbound::WaitForAcknowledgments(std::chrono::milliseconds timeout) {
  if (status_writer_) status_writer_->WaitForAcknowledgments(timeout);
}

void RosInbound::Acknowledge(uint64_t seq) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    acked_through_ = std::max<int64_t>(acked_through_, static_cast<int64_t>(seq));
  }
  cv_.notify_all();
}

void RosInbound::ComponentReady(const std::string& name) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    started_.insert(name);
  }
  cv_.notify_all();
}

void RosInbound::EndInput() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    end_requested_ = true;
  }
  cv_.notify_all();
}

bool RosInbound::WaitForEndOfStream(std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  return cv_.wait_for(lock, timeout, [this] { return stats_.end_of_stream_sent; });
}

std::string RosInbound::image_frame_id() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return image_frame_id_;
}

RosBridgeStats RosInbound::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  RosBridgeStats s = stats_;
  s.dropped_unsynchronized = sync_.stats().dropped_color + sync_.stats().dropped_depth;
  return s;
}

std::vector<eprosima::fastrtps::rtps::GUID_t> RosInbound::ros_reader_guids() const {
  std::vector<eprosima::fastrtps::rtps::GUID_t> guids;
  for (const auto* r : {color_reader_.get(), depth_reader_.get()}) {
    if (r != nullptr) guids.push_back(r->rtps_guid());
  }
  if (info_reader_) guids.push_back(info_reader_->rtps_guid());
  return guids;
}

// ---- Listener callbacks.

void RosInbound::OnImage(sensor_msgs::msg::Image&& image, bool is_color) {
  const std::string& topic = is_color ? options_.color_topic : options_.depth_topic;
  StampedImage item;
  std::string frame_id = image.header().frame_id();
  try {
    CheckFrameId(frame_id, topic + ".header.frame_id");
    item.stamp = TimeFromRos(image.header().stamp(), topic + ".header.stamp");
    if (is_color) {
      item.image = ColorFromRos(image, topic);
    } else {
      DepthImage d = DepthFromRos(image, options_.depth_unit, topic);
      item.image = d.depth;
      item.depth_scale = d.depth_scale;
    }
  } catch (const InputError& e) {
    std::lock_guard<std::mutex> lock(mutex_);
    RejectLocked(e.what());
    return;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<RgbdFrame> pairs;
  if (is_color) {
    ++stats_.color_received;
    if (!frame_id.empty()) image_frame_id_ = frame_id;
    pairs = sync_.AddColor(std::move(item));
  } else {
    ++stats_.depth_received;
    pairs = sync_.AddDepth(std::move(item));
  }
  stats_.dropped_unsynchronized = sync_.stats().dropped_color + sync_.stats().dropped_depth;
  for (RgbdFrame& pair : pairs) AddFrameLocked(std::move(pair));
}

void RosInbound::AddFrameLocked(RgbdFrame&& pair) {
  if (!camera_) {
    ++stats_.dropped_no_camera_info;
    if (ShouldLog(stats_.dropped_no_camera_info)) {
      LOG_WARNING << "ros2 bridge: frame dropped: no CameraInfo received yet on "
                  << options_.camera_info_topic;
    }
    return;
  }
  const PinholeCamera& c = camera_->camera;
  const cv::Size color_size = pair.rgb.size();
  const cv::Size depth_size = pair.depth.size();
  std::string error;
  if (depth_size != color_size) {
    error = options_.depth_topic + ".width/height: depth " + std::to_string(depth_size.width) +
            "x" + std::to_string(depth_size.height) + " differs from colour " +
            std::to_string(color_size.width) + "x" + std::to_string(color_size.height) +
            " (subscribe to the depth image aligned to colour)";
  } else if (color_size != cv::Size(c.width, c.height)) {
    error = options_.camera_info_topic + ".width/height: CameraInfo " + std::to_string(c.width) +
            "x" + std::to_string(c.height) + " differs from the images " +
            std::to_string(color_size.width) + "x" + std::to_string(color_size.height);
  }
  if (!error.empty()) {
    RejectLocked(error);
    return;
  }
  RgbdFrameData frame;
  frame.stamp = pair.stamp;
  frame.frame_id = image_frame_id_.empty() ? "camera" : image_frame_id_;
  frame.camera = c;
  frame.depth_scale = pair.depth_scale;
  frame.rgb = rectifier_->Color(pair.rgb);
  frame.depth = rectifier_->Depth(pair.depth);
  pending_.push_back(std::move(frame));
  last_frame_time_ = Clock::now();
  while (pending_.size() > options_.max_pending_frames) {
    pending_.pop_front();
    ++stats_.dropped_pending;
    head_wait_start_.reset();
  }
  cv_.notify_all();
}

void RosInbound::OnCameraInfo(sensor_msgs::msg::CameraInfo&& info) {
  try {
    CheckFrameId(info.header().frame_id(), options_.camera_info_topic + ".header.frame_id");
    RosCamera c = CameraFromRos(info, options_.camera_info_topic);
    if (camera_ && *camera_ == c) {
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.camera_info_received;
      return;
    }
    // A new or changed calibration: rectification maps (outside the lock, ~10 ms).
    auto r = std::make_unique<ImageRectifier>(c);
    std::lock_guard<std::mutex> lock(mutex_);
    ++stats_.camera_info_received;
    const PinholeCamera& p = c.camera;
    LOG_INFO << "ros2 bridge: camera " << p.width << "x" << p.height << " fx " << p.fx << " fy "
             << p.fy << " cx " << p.cx << " cy " << p.cy << " (" << info.distortion_model()
             << ") from " << options_.camera_info_topic << "; the SLAM settings (Camera.*) must "
             << "match";
    if (c.rectify) {
      LOG_WARNING << "ros2 bridge: " << info.distortion_model()
                  << " distortion is not the pipeline's model (k1 k2 p1 p2 k3): the bridge "
                     "rectifies the images to the same K without distortion; set Camera.k1, "
                     "k2, p1, p2, k3 to 0 in the SLAM settings";
    }
    camera_ = c;
    rectifier_ = std::move(r);
  } catch (const InputError& e) {
    std::lock_guard<std::mutex> lock(mutex_);
    RejectLocked(e.what());
  }
}

// The middleware's totals for one reader replace that topic's count; every new loss is logged
// (the first few, then every 100th) with what usually causes it.
void RosInbound::OnLoss(const std::string& topic, const dds::ReaderLosses& losses) {
  std::lock_guard<std::mutex> lock(mutex_);
  const size_t total = static_cast<size_t>(losses.lost + losses.rejected);
  size_t& known = stats_.lost_by_topic[topic];
  if (total <= known) return;
  const size_t before = known;
  known = total;
  stats_.samples_lost = 0;
  for (const auto& [name, count] : stats_.lost_by_topic) stats_.samples_lost += count;
  for (size_t n = before + 1; n <= total; ++n) {
    if (!ShouldLog(n)) continue;
    LOG_WARNING << "ros2 bridge: " << topic << ": a sample was lost before it reached the bridge ("
                << losses.lost << " lost in transport, " << losses.rejected
                << " rejected by the reader"
                << (losses.rejected > 0 ? " (" + losses.last_rejected_reason + ")" : "")
                << " so far); a large image is sent in fragments and lost whole when the socket "
                   "buffers overflow or a fragment is dropped";
    break;
  }
}

// Counts a rejected sample under its kind (the field before ": " in the reason) and logs the
// first of each kind (locked).
void RosInbound::RejectLocked(const std::string& reason) {
  const size_t colon = reason.find(": ");
  const std::string kind = colon == std::string::npos ? reason : reason.substr(0, colon);
  ++stats_.bad_samples;
  if (++stats_.rejected[kind] == 1) {
    LOG_WARNING << "ros2 bridge: rejected a sample: " << reason << " (further samples rejected for "
                << kind << " are counted, see the final statistics)";
  }
}

// Components of wait_for_components that have not announced READY (locked).
std::string RosInbound::MissingComponentsLocked() const {
  std::string names;
  for (const std::string& name : options_.wait_for_components) {
    if (!started_.count(name)) names += (names.empty() ? "" : ", ") + name;
  }
  return names;
}

int RosInbound::ExpectedFrameReaders() const {
  int n = 0;
  for (const std::string& name : options_.wait_for_components) {
    if (name == "slam" || name == "detector") ++n;
  }
  return n;
}

// True once the frame consumers are there (see RosBridgeOptions::wait_for_components).
bool RosInbound::ConsumersReadyLocked() {
  if (consumers_ready_) return true;
  const std::string missing = MissingComponentsLocked();
  const int readers = frame_writer_->matched();
  if (missing.empty() && readers >= ExpectedFrameReaders()) {
    consumers_ready_ = true;
    LOG_INFO << "ros2 bridge: pipeline ready (" << readers << " frame readers)";
  } else if (Clock::now() > consumers_deadline_) {
    consumers_ready_ = true;
    LOG_WARNING << "ros2 bridge: after " << options_.wait_for_components_s << " s, "
                << (missing.empty() ? "" : "no start announcement from " + missing + "; ")
                << readers << " of " << ExpectedFrameReaders()
                << " frame readers; forwarding anyway";
  }
  return consumers_ready_;
}

// ---- Forwarding thread (back-pressure window as the player's).
void RosInbound::Loop() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!quit_) {
    if (!pending_.empty()) {
      if (!ConsumersReadyLocked()) {
        cv_.wait_for(lock, std::chrono::milliseconds(20));
        continue;
      }
      const int64_t k = static_cast<int64_t>(next_seq_);
      const bool window_open =
          options_.window == 0 || k < options_.window || acked_through_ >= k - options_.window;
      bool timed_out = false;
      if (!window_open) {
        if (!head_wait_start_) head_wait_start_ = Clock::now();
        timed_out = Clock::now() - *head_wait_start_ >
                    std::chrono::duration<double>(options_.ack_timeout_s);
      }
      if (window_open || timed_out) {
        if (timed_out) ++stats_.ack_timeouts;
        head_wait_start_.reset();
        RgbdFrameData frame = std::move(pending_.front());
        pending_.pop_front();
        frame.seq = next_seq_++;
        ++stats_.frames_forwarded;
        lock.unlock();
        frame_writer_->Write(RgbdFrameToMsg(frame));
        lock.lock();
        continue;
      }
    } else if (!end_requested_ && options_.end_of_stream_idle_s > 0 && next_seq_ > 0 &&
               Clock::now() - last_frame_time_ >
                   std::chrono::duration<double>(options_.end_of_stream_idle_s)) {
      LOG_INFO << "ros2 bridge: no frames for " << options_.end_of_stream_idle_s << " s";
      end_requested_ = true;
      continue;
    } else if (end_requested_ && !stats_.end_of_stream_sent && status_writer_) {
      const uint64_t n = next_seq_;
      stats_.end_of_stream_sent = true;
      lock.unlock();
      status_writer_->Write(MakeStatus(StreamEvent::kEndOfStream, n, n > 0 ? n - 1 : 0));
      LOG_INFO << "ros2 bridge: END_OF_STREAM after " << n << " frames";
      lock.lock();
      cv_.notify_all();
      continue;
    }
    cv_.wait_for(lock, std::chrono::milliseconds(20));
  }
}

}  // namespace dygslam::ros2
