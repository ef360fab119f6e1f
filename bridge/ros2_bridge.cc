#include "bridge/ros2_bridge.h"

#include <cmath>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <optional>
#include <set>
#include <thread>

#include "bridge/rgbd_sync.h"
#include "bridge/ros2_convert.h"
#include "bridge/ros2_endpoint.h"
#include "bridge/ros2_graph_type.h"
#include "components/convert.h"
#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "components/dds/qos.h"
#include "core/base/error.h"
#include "core/base/log.h"
#include "dygslam_msg/CameraPosePubSubTypes.h"
#include "dygslam_msg/DetectionsPubSubTypes.h"
#include "dygslam_msg/MapUpdatePubSubTypes.h"
#include "dygslam_msg/RgbdFramePubSubTypes.h"
#include "dygslam_msg/StreamStatusPubSubTypes.h"
#include "dygslam_msg/TrajectoryPubSubTypes.h"
#include "geometry_msgs/msg/PoseStampedPubSubTypes.h"
#include "nav_msgs/msg/OdometryPubSubTypes.h"
#include "nav_msgs/msg/PathPubSubTypes.h"
#include "octomap_msgs/msg/OctomapPubSubTypes.h"
#include "sensor_msgs/msg/CameraInfoPubSubTypes.h"
#include "sensor_msgs/msg/ImagePubSubTypes.h"
#include "tf2_msgs/msg/TFMessagePubSubTypes.h"
#include "vision_msgs/msg/Detection2DArrayPubSubTypes.h"

namespace dygslam::ros2 {

using Clock = std::chrono::steady_clock;

void RosBridgeOptions::Check() const {
  DYGSLAM_CHECK_OPTION(inbound || outbound, "inbound or outbound");
  if (inbound) {
    DdsTopicName(color_topic, "color_topic");
    DdsTopicName(depth_topic, "depth_topic");
    DdsTopicName(camera_info_topic, "camera_info_topic");
    DYGSLAM_CHECK_OPTION(depth_unit > 0 && std::isfinite(depth_unit), "depth_unit");
    DYGSLAM_CHECK_OPTION(max_stamp_difference_s >= 0 && std::isfinite(max_stamp_difference_s),
                         "max_stamp_difference_s");
    DYGSLAM_CHECK_OPTION(window >= 0 && window < dds::kFrameHistoryDepth, "window");
    DYGSLAM_CHECK_OPTION(max_pending_frames >= 1, "max_pending_frames");
    DYGSLAM_CHECK_OPTION(ack_timeout_s > 0, "ack_timeout_s");
    DYGSLAM_CHECK_OPTION(end_of_stream_idle_s >= 0, "end_of_stream_idle_s");
    DYGSLAM_CHECK_OPTION(wait_for_components_s >= 0 && std::isfinite(wait_for_components_s),
                         "wait_for_components_s");
    for (const std::string& name : wait_for_components) {
      DYGSLAM_CHECK_OPTION(!name.empty(), "wait_for_components (empty name)");
    }
  }
  if (outbound) {
    DdsTopicName(pose_topic, "pose_topic");
    DdsTopicName(odom_topic, "odom_topic");
    DdsTopicName(path_topic, "path_topic");
    DdsTopicName(tf_topic, "tf_topic");
    DdsTopicName(tf_static_topic, "tf_static_topic");
    DdsTopicName(detections_topic, "detections_topic");
    DdsTopicName(octomap_topic, "octomap_topic");
    DYGSLAM_CHECK_OPTION(!map_frame.empty(), "map_frame");
    DYGSLAM_CHECK_OPTION(!world_frame.empty(), "world_frame");
    DYGSLAM_CHECK_OPTION(!camera_frame.empty(), "camera_frame");
    const std::pair<const char*, const std::string*> frames[] = {{"map_frame", &map_frame},
                                                                 {"world_frame", &world_frame},
                                                                 {"camera_frame", &camera_frame},
                                                                 {"image_frame", &image_frame}};
    for (const auto& [name, frame] : frames) {
      if (!frame->empty() && (*frame)[0] == '/') {
        throw InvalidOptions(std::string("invalid option ") + name + ": '" + *frame +
                             "' starts with '/' (tf2 refuses frame ids with a leading '/')");
      }
    }
    DYGSLAM_CHECK_OPTION(map_frame != camera_frame && map_frame != world_frame,
                         "map_frame distinct from camera_frame and world_frame");
    DYGSLAM_CHECK_OPTION(path_every >= 0, "path_every");
  }
  if (announce_node) {
    CheckNodeName(node_name, "node_name");
    CheckNodeNamespace(node_namespace, "node_namespace");
  }
}

dds::ParticipantOptions RosParticipantOptions(int domain_id, bool shared_memory) {
  dds::ParticipantOptions o;
  o.domain_id = domain_id;
  o.name = "dygslam_ros2_bridge";
  o.xml_profile_name = "dygslam_ros";
  o.network.all_interfaces = true;
  o.network.shared_memory = shared_memory;
  o.user_data = kRosEnclaveUserData;
  return o;
}

void RosBridgeOptions::ApplyCameraPreset(const std::string& preset) {
  if (preset == "realsense") {
    color_topic = "/camera/camera/color/image_raw";
    depth_topic = "/camera/camera/aligned_depth_to_color/image_raw";
    camera_info_topic = "/camera/camera/color/camera_info";
  } else if (preset == "realsense-legacy") {
    color_topic = "/camera/color/image_raw";
    depth_topic = "/camera/aligned_depth_to_color/image_raw";
    camera_info_topic = "/camera/color/camera_info";
  } else if (preset == "azure-kinect") {
    color_topic = "/rgb/image_raw";
    depth_topic = "/depth_to_rgb/image_raw";
    camera_info_topic = "/rgb/camera_info";
  } else if (preset == "kinect") {
    color_topic = "/image_raw";
    depth_topic = "/depth/image_raw";
    camera_info_topic = "/camera_info";
  } else {
    throw InvalidOptions("invalid option camera preset: '" + preset +
                         "' (realsense | realsense-legacy | azure-kinect | kinect)");
  }
}

namespace {

// Logs the first few occurrences, then every 100th.
bool ShouldLog(size_t count) { return count <= 5 || count % 100 == 0; }

Guid ToGuid(const eprosima::fastrtps::rtps::GUID_t& g) {
  Guid out{};
  std::copy(g.guidPrefix.value, g.guidPrefix.value + 12, out.begin());
  std::copy(g.entityId.value, g.entityId.value + 4, out.begin() + 12);
  return out;
}

msg::StreamStatus MakeStatus(StreamEvent event, uint64_t num_frames, uint64_t seq) {
  msg::StreamStatus s;
  s.kind(static_cast<uint8_t>(event));
  s.source("ros2_bridge");
  s.num_frames(num_frames);
  s.header().seq(seq);
  return s;
}

}  // namespace

struct RosBridge::Impl {
  std::shared_ptr<dds::Participant> participant;      // pipeline topics
  std::shared_ptr<dds::Participant> ros_participant;  // ROS 2 topics
  RosBridgeOptions options;
  Rigid3d map_from_world;

  mutable std::mutex mutex;  // guards everything below except the endpoints
  std::condition_variable cv;
  RosBridgeStats stats;
  bool quit = false;

  // Inbound.
  RgbdSynchronizer sync;
  std::optional<RosCamera> camera;
  std::unique_ptr<ImageRectifier> rectifier;  // for `camera`
  std::string image_frame_id;
  std::deque<RgbdFrameData> pending;
  uint64_t next_seq = 0;
  int64_t acked_through = -1;  // highest frame seq slam acknowledged
  std::optional<Clock::time_point> head_wait_start;
  Clock::time_point last_frame_time = Clock::now();
  bool end_requested = false;
  bool slam_done = false;
  std::set<std::string> started;  // STARTED announcements seen (component names)
  bool consumers_ready = false;   // wait_for_components announced (or timed out)
  Clock::time_point consumers_deadline;

  // Outbound (worker thread).
  BlockingQueue<std::function<void()>> outbound_jobs;
  std::vector<StampedPose> online_path;  // world_from_cam
  std::optional<StampedPose> previous_map_from_cam;
  bool final_path = false;
  bool mapper_done = false;

  std::shared_ptr<RosSession> ros;  // default-partition publisher / subscriber (ROS side)
  // Endpoints (writers first: readers' callbacks use them; readers are reset first).
  std::unique_ptr<dds::Writer<msg::RgbdFramePubSubType>> frame_writer;
  std::unique_ptr<dds::Writer<msg::StreamStatusPubSubType>> status_writer;
  std::unique_ptr<RosWriter<geometry_msgs::msg::PoseStampedPubSubType>> pose_writer;
  std::unique_ptr<RosWriter<nav_msgs::msg::OdometryPubSubType>> odom_writer;
  std::unique_ptr<RosWriter<nav_msgs::msg::PathPubSubType>> path_writer;
  std::unique_ptr<RosWriter<tf2_msgs::msg::TFMessagePubSubType>> tf_writer;
  std::unique_ptr<RosWriter<tf2_msgs::msg::TFMessagePubSubType>> tf_static_writer;
  std::unique_ptr<RosWriter<vision_msgs::msg::Detection2DArrayPubSubType>> detections_writer;
  std::unique_ptr<RosWriter<octomap_msgs::msg::OctomapPubSubType>> octomap_writer;
  std::unique_ptr<RosWriter<ParticipantEntitiesInfoPubSubType<RosDistro::kHumble>>> graph_humble;
  std::unique_ptr<RosWriter<ParticipantEntitiesInfoPubSubType<RosDistro::kJazzy>>> graph_jazzy;
  RosParticipantEntities graph;

  std::unique_ptr<RosReader<sensor_msgs::msg::ImagePubSubType>> color_reader, depth_reader;
  std::unique_ptr<RosReader<sensor_msgs::msg::CameraInfoPubSubType>> info_reader;
  std::unique_ptr<dds::Reader<msg::CameraPosePubSubType>> pose_reader;
  std::unique_ptr<dds::Reader<msg::TrajectoryPubSubType>> trajectory_reader;
  std::unique_ptr<dds::Reader<msg::DetectionsPubSubType>> detections_reader;
  std::unique_ptr<dds::Reader<msg::MapUpdatePubSubType>> map_reader;
  std::unique_ptr<dds::Reader<msg::StreamStatusPubSubType>> status_reader;

  std::thread inbound_thread, outbound_thread;

  Impl(std::shared_ptr<dds::Participant> p, std::shared_ptr<dds::Participant> r,
       const RosBridgeOptions& o)
      : participant(std::move(p)),
        ros_participant(std::move(r)),
        options(o),
        map_from_world(MapFromWorld(o.ros_axes)),
        sync(RgbdSyncOptions{o.max_stamp_difference_s, 16}) {}

  // ---- Inbound: listener callbacks.
  void OnImage(sensor_msgs::msg::Image&& image, bool is_color) {
    const std::string& topic = is_color ? options.color_topic : options.depth_topic;
    StampedImage item;
    std::string frame_id = image.header().frame_id();
    try {
      CheckFrameId(frame_id, topic + ".header.frame_id");
      item.stamp = TimeFromRos(image.header().stamp(), topic + ".header.stamp");
      if (is_color) {
        item.image = ColorFromRos(image, topic);
      } else {
        DepthImage d = DepthFromRos(image, options.depth_unit, topic);
        item.image = d.depth;
        item.depth_scale = d.depth_scale;
      }
    } catch (const InputError& e) {
      std::lock_guard<std::mutex> lock(mutex);
      RejectLocked(e.what());
      return;
    }
    std::lock_guard<std::mutex> lock(mutex);
    std::vector<RgbdFrame> pairs;
    if (is_color) {
      ++stats.color_received;
      if (!frame_id.empty()) image_frame_id = frame_id;
      pairs = sync.AddColor(std::move(item));
    } else {
      ++stats.depth_received;
      pairs = sync.AddDepth(std::move(item));
    }
    stats.dropped_unsynchronized = sync.stats().dropped_color + sync.stats().dropped_depth;
    for (RgbdFrame& pair : pairs) AddFrameLocked(std::move(pair));
  }

  void AddFrameLocked(RgbdFrame&& pair) {
    if (!camera) {
      ++stats.dropped_no_camera_info;
      if (ShouldLog(stats.dropped_no_camera_info)) {
        LOG_WARNING << "ros2 bridge: frame dropped: no CameraInfo received yet on "
                    << options.camera_info_topic;
      }
      return;
    }
    const PinholeCamera& c = camera->camera;
    const cv::Size color_size = pair.rgb.size();
    const cv::Size depth_size = pair.depth.size();
    std::string error;
    if (depth_size != color_size) {
      error = options.depth_topic + ".width/height: depth " + std::to_string(depth_size.width) +
              "x" + std::to_string(depth_size.height) + " differs from colour " +
              std::to_string(color_size.width) + "x" + std::to_string(color_size.height) +
              " (subscribe to the depth image aligned to colour)";
    } else if (color_size != cv::Size(c.width, c.height)) {
      error = options.camera_info_topic + ".width/height: CameraInfo " + std::to_string(c.width) +
              "x" + std::to_string(c.height) + " differs from the images " +
              std::to_string(color_size.width) + "x" + std::to_string(color_size.height);
    }
    if (!error.empty()) {
      RejectLocked(error);
      return;
    }
    RgbdFrameData frame;
    frame.stamp = pair.stamp;
    frame.frame_id = image_frame_id.empty() ? "camera" : image_frame_id;
    frame.camera = c;
    frame.depth_scale = pair.depth_scale;
    frame.rgb = rectifier->Color(pair.rgb);
    frame.depth = rectifier->Depth(pair.depth);
    pending.push_back(std::move(frame));
    last_frame_time = Clock::now();
    while (pending.size() > options.max_pending_frames) {
      pending.pop_front();
      ++stats.dropped_pending;
      head_wait_start.reset();
    }
    cv.notify_all();
  }

  void OnCameraInfo(sensor_msgs::msg::CameraInfo&& info) {
    try {
      CheckFrameId(info.header().frame_id(), options.camera_info_topic + ".header.frame_id");
      RosCamera c = CameraFromRos(info, options.camera_info_topic);
      if (camera && *camera == c) {
        std::lock_guard<std::mutex> lock(mutex);
        ++stats.camera_info_received;
        return;
      }
      // A new or changed calibration: rectification maps (outside the lock, ~10 ms).
      auto r = std::make_unique<ImageRectifier>(c);
      std::lock_guard<std::mutex> lock(mutex);
      ++stats.camera_info_received;
      const PinholeCamera& p = c.camera;
      LOG_INFO << "ros2 bridge: camera " << p.width << "x" << p.height << " fx " << p.fx << " fy "
               << p.fy << " cx " << p.cx << " cy " << p.cy << " (" << info.distortion_model()
               << ") from " << options.camera_info_topic << "; the SLAM settings (Camera.*) must "
               << "match";
      if (c.rectify) {
        LOG_WARNING << "ros2 bridge: " << info.distortion_model()
                    << " distortion is not the pipeline's model (k1 k2 p1 p2 k3): the bridge "
                       "rectifies the images to the same K without distortion; set Camera.k1, "
                       "k2, p1, p2, k3 to 0 in the SLAM settings";
      }
      camera = c;
      rectifier = std::move(r);
    } catch (const InputError& e) {
      std::lock_guard<std::mutex> lock(mutex);
      RejectLocked(e.what());
    }
  }

  // Counts a rejected sample under its kind (the field before ": " in the reason) and logs the
  // first of each kind (locked).
  void RejectLocked(const std::string& reason) {
    const size_t colon = reason.find(": ");
    const std::string kind = colon == std::string::npos ? reason : reason.substr(0, colon);
    ++stats.bad_samples;
    if (++stats.rejected[kind] == 1) {
      LOG_WARNING << "ros2 bridge: rejected a sample: " << reason
                  << " (further samples rejected for " << kind
                  << " are counted, see the final statistics)";
    }
  }

  // Components of wait_for_components that have not announced STARTED (locked).
  std::string MissingComponentsLocked() const {
    std::string names;
    for (const std::string& name : options.wait_for_components) {
      if (!started.count(name)) names += (names.empty() ? "" : ", ") + name;
    }
    return names;
  }

  int ExpectedFrameReaders() const {
    int n = 0;
    for (const std::string& name : options.wait_for_components) {
      if (name == "slam" || name == "detector") ++n;
    }
    return n;
  }

  // True once the frame consumers are there (see RosBridgeOptions::wait_for_components).
  bool ConsumersReadyLocked() {
    if (consumers_ready) return true;
    const std::string missing = MissingComponentsLocked();
    const int readers = frame_writer->matched();
    if (missing.empty() && readers >= ExpectedFrameReaders()) {
      consumers_ready = true;
      LOG_INFO << "ros2 bridge: pipeline ready (" << readers << " frame readers)";
    } else if (Clock::now() > consumers_deadline) {
      consumers_ready = true;
      LOG_WARNING << "ros2 bridge: after " << options.wait_for_components_s << " s, "
                  << (missing.empty() ? "" : "no start announcement from " + missing + "; ")
                  << readers << " of " << ExpectedFrameReaders()
                  << " frame readers; forwarding anyway";
    }
    return consumers_ready;
  }

  // ---- Inbound: forwarding thread (back-pressure window as the player's).
  void InboundLoop() {
    std::unique_lock<std::mutex> lock(mutex);
    while (!quit) {
      if (!pending.empty()) {
        if (!ConsumersReadyLocked()) {
          cv.wait_for(lock, std::chrono::milliseconds(20));
          continue;
        }
        const int64_t k = static_cast<int64_t>(next_seq);
        const bool window_open =
            options.window == 0 || k < options.window || acked_through >= k - options.window;
        bool timed_out = false;
        if (!window_open) {
          if (!head_wait_start) head_wait_start = Clock::now();
          timed_out = Clock::now() - *head_wait_start >
                      std::chrono::duration<double>(options.ack_timeout_s);
        }
        if (window_open || timed_out) {
          if (timed_out) ++stats.ack_timeouts;
          head_wait_start.reset();
          RgbdFrameData frame = std::move(pending.front());
          pending.pop_front();
          frame.seq = next_seq++;
          ++stats.frames_forwarded;
          lock.unlock();
          frame_writer->Write(RgbdFrameToMsg(frame));
          lock.lock();
          continue;
        }
      } else if (!end_requested && options.end_of_stream_idle_s > 0 && next_seq > 0 &&
                 Clock::now() - last_frame_time >
                     std::chrono::duration<double>(options.end_of_stream_idle_s)) {
        LOG_INFO << "ros2 bridge: no frames for " << options.end_of_stream_idle_s << " s";
        end_requested = true;
        continue;
      } else if (end_requested && !stats.end_of_stream_sent && status_writer) {
        const uint64_t n = next_seq;
        stats.end_of_stream_sent = true;
        lock.unlock();
        status_writer->Write(MakeStatus(StreamEvent::kEndOfStream, n, n > 0 ? n - 1 : 0));
        LOG_INFO << "ros2 bridge: END_OF_STREAM after " << n << " frames";
        lock.lock();
        cv.notify_all();
        continue;
      }
      cv.wait_for(lock, std::chrono::milliseconds(20));
    }
  }

  // ---- Outbound: listener callbacks queue jobs for the worker thread.
  void OnCameraPose(msg::CameraPose&& m) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      acked_through = std::max<int64_t>(acked_through, static_cast<int64_t>(m.header().seq()));
    }
    cv.notify_all();
    if (!options.outbound || !m.has_pose()) return;
    outbound_jobs.Push([this, m = std::move(m)] {
      const Timestamp stamp = TimeFromMsg(m.header().stamp(), "CameraPose.header.stamp");
      const Rigid3d world_from_cam = PoseFromMsg(m.world_from_cam(), "CameraPose.world_from_cam");
      const Rigid3d map_from_cam = map_from_world * world_from_cam;
      pose_writer->Write(PoseStampedToRos(map_from_cam, stamp, options.map_frame));
      const StampedPose current{stamp, map_from_cam};
      odom_writer->Write(
          OdometryToRos(current, previous_map_from_cam, options.map_frame, options.camera_frame));
      previous_map_from_cam = current;
      size_t transforms = 0;
      if (options.publish_tf) {
        tf2_msgs::msg::TFMessage tf;
        tf.transforms().push_back(
            TransformToRos(map_from_cam, stamp, options.map_frame, options.camera_frame));
        tf_writer->Write(tf);
        transforms = 1;
      }
      bool path = false;
      if (!final_path) {
        online_path.push_back({stamp, world_from_cam});
        if (options.path_every > 0 && online_path.size() % options.path_every == 0) {
          path_writer->Write(PathToRos(online_path, map_from_world, stamp, options.map_frame));
          path = true;
        }
      }
      std::lock_guard<std::mutex> lock(mutex);
      ++stats.poses;
      stats.transforms += transforms;
      if (path) ++stats.paths;
    });
  }

  void OnTrajectory(msg::Trajectory&& m) {
    if (m.keyframes_only()) return;
    outbound_jobs.Push([this, m = std::move(m)] {
      const std::vector<StampedPose> poses = TrajectoryFromMsg(m);
      const Timestamp stamp = poses.empty() ? Timestamp() : poses.back().stamp;
      path_writer->Write(PathToRos(poses, map_from_world, stamp, options.map_frame));
      final_path = true;
      std::lock_guard<std::mutex> lock(mutex);
      ++stats.paths;
    });
  }

  void OnDetections(msg::Detections&& m) {
    outbound_jobs.Push([this, m = std::move(m)] {
      const Timestamp stamp = TimeFromMsg(m.header().stamp(), "Detections.header.stamp");
      const std::vector<Detection> dets = DetectionsFromMsg(m);
      std::string frame = options.image_frame;
      if (frame.empty()) {
        std::lock_guard<std::mutex> lock(mutex);
        frame = image_frame_id;
      }
      if (frame.empty()) frame = m.header().frame_id().empty() ? "camera" : m.header().frame_id();
      detections_writer->Write(DetectionsToRos(dets, stamp, frame));
      std::lock_guard<std::mutex> lock(mutex);
      ++stats.detections;
    });
  }

  void OnMapUpdate(msg::MapUpdate&& m) {
    outbound_jobs.Push([this, m = std::move(m)] {
      const Timestamp stamp = TimeFromMsg(m.header().stamp(), "MapUpdate.header.stamp");
      octomap_writer->Write(OctomapToRos(m.octree_bt(), stamp, options.world_frame));
      std::lock_guard<std::mutex> lock(mutex);
      ++stats.maps;
    });
  }

  void OutboundLoop() {
    while (true) {
      {
        std::lock_guard<std::mutex> lock(mutex);
        if (quit && outbound_jobs.size() == 0) return;
      }
      auto job = outbound_jobs.Pop(std::chrono::milliseconds(20));
      if (!job) continue;
      try {
        (*job)();
      } catch (const InputError& e) {
        std::lock_guard<std::mutex> lock(mutex);
        ++stats.bad_pipeline_samples;
        LOG_WARNING << "ros2 bridge: dropped pipeline sample: " << e.what();
      }
    }
  }

  void Start() {
    auto& p = participant;
    const auto& o = options;
    const RosQos reliable = RosQos::Default();
    ros = RosSession::Create(ros_participant);
    consumers_deadline = Clock::now() + std::chrono::milliseconds(
                                            static_cast<int64_t>(o.wait_for_components_s * 1000));
    if (o.inbound) {
      frame_writer = std::make_unique<dds::Writer<msg::RgbdFramePubSubType>>(
          p, dds::topics::kRgbdFrame, dds::TopicKind::kRgbdFrame);
      status_writer = std::make_unique<dds::Writer<msg::StreamStatusPubSubType>>(
          p, dds::topics::kStreamStatus, dds::TopicKind::kStreamStatus);
      // slam takes frames only from announced writers (components/protocol.h).
      status_writer->Write(ToMsg(ComponentStatus::Started(
          ComponentKind::kRos2Bridge, {{DataTopic::kFrames, frame_writer->guid()}})));
    }
    if (o.outbound) {
      pose_writer = std::make_unique<RosWriter<geometry_msgs::msg::PoseStampedPubSubType>>(
          ros, DdsTopicName(o.pose_topic, "pose_topic"), reliable);
      odom_writer = std::make_unique<RosWriter<nav_msgs::msg::OdometryPubSubType>>(
          ros, DdsTopicName(o.odom_topic, "odom_topic"), reliable);
      path_writer = std::make_unique<RosWriter<nav_msgs::msg::PathPubSubType>>(
          ros, DdsTopicName(o.path_topic, "path_topic"), reliable);
      tf_writer = std::make_unique<RosWriter<tf2_msgs::msg::TFMessagePubSubType>>(
          ros, DdsTopicName(o.tf_topic, "tf_topic"), RosQos{true, false, 100});
      tf_static_writer = std::make_unique<RosWriter<tf2_msgs::msg::TFMessagePubSubType>>(
          ros, DdsTopicName(o.tf_static_topic, "tf_static_topic"), RosQos::TransientLocal());
      detections_writer = std::make_unique<RosWriter<vision_msgs::msg::Detection2DArrayPubSubType>>(
          ros, DdsTopicName(o.detections_topic, "detections_topic"), reliable);
      octomap_writer = std::make_unique<RosWriter<octomap_msgs::msg::OctomapPubSubType>>(
          ros, DdsTopicName(o.octomap_topic, "octomap_topic"), RosQos::TransientLocal());
      // The static map -> SLAM world transform (the octree is expressed in the world frame).
      tf2_msgs::msg::TFMessage tf_static;
      tf_static.transforms().push_back(
          TransformToRos(map_from_world, Timestamp(), o.map_frame, o.world_frame));
      tf_static_writer->Write(tf_static);
    }
    inbound_thread = std::thread([this] { InboundLoop(); });
    outbound_thread = std::thread([this] { OutboundLoop(); });

    // Readers last: their callbacks need the writers and threads.
    pose_reader = std::make_unique<dds::Reader<msg::CameraPosePubSubType>>(
        p, dds::topics::kCameraPose, dds::TopicKind::kCameraPose,
        [this](msg::CameraPose&& m) { OnCameraPose(std::move(m)); });
    status_reader = std::make_unique<dds::Reader<msg::StreamStatusPubSubType>>(
        p, dds::topics::kStreamStatus, dds::TopicKind::kStreamStatus,
        [this](msg::StreamStatus&& s) {
          std::lock_guard<std::mutex> lock(mutex);
          if (s.kind() == static_cast<uint8_t>(StreamEvent::kReady)) started.insert(s.source());
          if (s.kind() == static_cast<uint8_t>(StreamEvent::kComponentDone)) {
            if (s.source() == "slam") slam_done = true;
            if (s.source() == "mapper") mapper_done = true;
          }
          cv.notify_all();
        });
    if (o.outbound) {
      trajectory_reader = std::make_unique<dds::Reader<msg::TrajectoryPubSubType>>(
          p, dds::topics::kTrajectory, dds::TopicKind::kTrajectory,
          [this](msg::Trajectory&& m) { OnTrajectory(std::move(m)); });
      detections_reader = std::make_unique<dds::Reader<msg::DetectionsPubSubType>>(
          p, dds::topics::kDetections, dds::TopicKind::kDetections,
          [this](msg::Detections&& m) { OnDetections(std::move(m)); });
      map_reader = std::make_unique<dds::Reader<msg::MapUpdatePubSubType>>(
          p, dds::topics::kMapUpdate, dds::TopicKind::kMapUpdate,
          [this](msg::MapUpdate&& m) { OnMapUpdate(std::move(m)); });
    }
    if (o.inbound) {
      const RosQos sensor = RosQos::SensorData();
      color_reader = std::make_unique<RosReader<sensor_msgs::msg::ImagePubSubType>>(
          ros, DdsTopicName(o.color_topic, "color_topic"), sensor,
          [this](sensor_msgs::msg::Image&& m) { OnImage(std::move(m), true); });
      depth_reader = std::make_unique<RosReader<sensor_msgs::msg::ImagePubSubType>>(
          ros, DdsTopicName(o.depth_topic, "depth_topic"), sensor,
          [this](sensor_msgs::msg::Image&& m) { OnImage(std::move(m), false); });
      info_reader = std::make_unique<RosReader<sensor_msgs::msg::CameraInfoPubSubType>>(
          ros, DdsTopicName(o.camera_info_topic, "camera_info_topic"), sensor,
          [this](sensor_msgs::msg::CameraInfo&& m) { OnCameraInfo(std::move(m)); });
    }
    AnnounceNode();
  }

  // The ROS 2 graph entry: one node owning the ROS readers and writers (ros2_graph.h).
  void AnnounceNode() {
    graph.participant = ToGuid(ros_participant->get()->guid());
    if (!options.announce_node) return;
    RosNodeEntities node;
    node.node_namespace = options.node_namespace;
    node.node_name = options.node_name;
    for (const auto* r : {color_reader.get(), depth_reader.get()}) {
      if (r != nullptr) node.readers.push_back(ToGuid(r->rtps_guid()));
    }
    if (info_reader) node.readers.push_back(ToGuid(info_reader->rtps_guid()));
    if (pose_writer) node.writers.push_back(ToGuid(pose_writer->rtps_guid()));
    if (odom_writer) node.writers.push_back(ToGuid(odom_writer->rtps_guid()));
    if (path_writer) node.writers.push_back(ToGuid(path_writer->rtps_guid()));
    for (const auto* w : {tf_writer.get(), tf_static_writer.get()}) {
      if (w != nullptr) node.writers.push_back(ToGuid(w->rtps_guid()));
    }
    if (detections_writer) node.writers.push_back(ToGuid(detections_writer->rtps_guid()));
    if (octomap_writer) node.writers.push_back(ToGuid(octomap_writer->rtps_guid()));
    graph.nodes = {node};
    // rmw's ros_discovery_info QoS: reliable, transient local, keep-last 1.
    if (options.ros_distro == RosDistro::kHumble) {
      graph_humble =
          std::make_unique<RosWriter<ParticipantEntitiesInfoPubSubType<RosDistro::kHumble>>>(
              ros, kRosDiscoveryTopic, RosQos::TransientLocal());
      graph_humble->Write(graph);
    } else {
      graph_jazzy =
          std::make_unique<RosWriter<ParticipantEntitiesInfoPubSubType<RosDistro::kJazzy>>>(
              ros, kRosDiscoveryTopic, RosQos::TransientLocal());
      graph_jazzy->Write(graph);
    }
    LOG_INFO << "ros2 bridge: ROS 2 node "
             << (options.node_namespace == "/" ? "" : options.node_namespace) << "/"
             << options.node_name << " (" << node.readers.size() << " subscriptions, "
             << node.writers.size() << " publishers; ros_discovery_info for "
             << RosDistroName(options.ros_distro) << ")";
  }

  void Stop() {
    color_reader.reset();
    depth_reader.reset();
    info_reader.reset();
    pose_reader.reset();
    trajectory_reader.reset();
    detections_reader.reset();
    map_reader.reset();
    status_reader.reset();
    {
      std::lock_guard<std::mutex> lock(mutex);
      quit = true;
    }
    cv.notify_all();
    if (inbound_thread.joinable()) inbound_thread.join();
    if (outbound_thread.joinable()) outbound_thread.join();
    // Let reliable ROS readers receive the last samples before the writers go away.
    const auto t = std::chrono::milliseconds(1000);
    if (path_writer) path_writer->WaitForAcknowledgments(t);
    if (octomap_writer) octomap_writer->WaitForAcknowledgments(t);
    if (status_writer) status_writer->WaitForAcknowledgments(t);
  }
};

RosBridge::RosBridge(std::shared_ptr<dds::Participant> pipeline,
                     std::shared_ptr<dds::Participant> ros, const RosBridgeOptions& options) {
  options.Check();
  if (ros == nullptr) ros = pipeline;
  impl_ = std::make_unique<Impl>(std::move(pipeline), std::move(ros), options);
  impl_->Start();
}

RosBridge::RosBridge(std::shared_ptr<dds::Participant> participant, const RosBridgeOptions& options)
    : RosBridge(participant, participant, options) {}

RosParticipantEntities RosBridge::graph_entry() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->graph;
}

RosBridge::~RosBridge() {
  if (impl_->options.end_of_stream_on_stop && impl_->options.inbound) {
    EndInput();
    std::unique_lock<std::mutex> lock(impl_->mutex);
    impl_->cv.wait_for(lock, std::chrono::seconds(2),
                       [this] { return impl_->stats.end_of_stream_sent; });
  }
  impl_->Stop();
}

void RosBridge::EndInput() {
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->end_requested = true;
  }
  impl_->cv.notify_all();
}

bool RosBridge::slam_done() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->slam_done;
}

bool RosBridge::outputs_done() const {
  const bool mapper_running = impl_->map_reader && impl_->map_reader->matched() > 0;
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->slam_done && (impl_->mapper_done || !mapper_running);
}

RosBridgeStats RosBridge::stats() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  RosBridgeStats s = impl_->stats;
  s.dropped_unsynchronized = impl_->sync.stats().dropped_color + impl_->sync.stats().dropped_depth;
  return s;
}

RosBridgeStats RunBridge(std::shared_ptr<dds::Participant> pipeline,
                         std::shared_ptr<dds::Participant> ros, const RosBridgeOptions& options,
                         const StopFlagPtr& stop) {
  RosBridge bridge(std::move(pipeline), std::move(ros), options);
  std::optional<Clock::time_point> slam_done_at;
  while (!stop->WaitFor(std::chrono::milliseconds(50))) {
    if (!bridge.stats().end_of_stream_sent || !bridge.slam_done()) continue;
    // After END_OF_STREAM: slam published its final trajectory; wait for the mapper's last map
    // (if a mapper is running) so both reach the ROS side, then stop.
    if (!slam_done_at) slam_done_at = Clock::now();
    if (bridge.outputs_done() || Clock::now() - *slam_done_at > std::chrono::seconds(60)) break;
  }
  RosBridgeStats stats = bridge.stats();
  return stats;
}

}  // namespace dygslam::ros2
