// The bridge = the inbound half (ros2_inbound.h: ROS 2 camera -> pipeline) + the outbound half
// (ros2_outbound.h: pipeline -> ROS 2) + what they share: the ROS participant (RosSession), the pipeline's
// CameraPose reader (slam's acknowledgements for the inbound window; poses for the outbound
// topics), the StreamStatus reader (READY / COMPONENT_DONE of the pipeline's components) and the
// ROS 2 graph entry of both halves' endpoints.
#include "bridge/ros2_bridge.h"

#include <cmath>
#include <condition_variable>
#include <mutex>
#include <optional>

#include "bridge/ros2_convert.h"
#include "bridge/ros2_endpoint.h"
#include "bridge/ros2_graph_type.h"
#include "bridge/ros2_inbound.h"
#include "bridge/ros2_outbound.h"
#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "components/dds/qos.h"
#include "core/base/error.h"
#include "core/base/log.h"
#include "dygslam_msg/CameraPosePubSubTypes.h"
#include "dygslam_msg/StreamStatusPubSubTypes.h"

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

Guid ToGuid(const eprosima::fastrtps::rtps::GUID_t& g) {
  Guid out{};
  std::copy(g.guidPrefix.value, g.guidPrefix.value + 12, out.begin());
  std::copy(g.entityId.value, g.entityId.value + 4, out.begin() + 12);
  return out;
}

}  // namespace

struct RosBridge::Impl {
  std::shared_ptr<dds::Participant> participant;      // pipeline topics
  std::shared_ptr<dds::Participant> ros_participant;  // ROS 2 topics
  RosBridgeOptions options;

  mutable std::mutex mutex;  // guards slam_done, mapper_done, graph
  bool slam_done = false;
  bool mapper_done = false;
  RosParticipantEntities graph;

  std::shared_ptr<RosSession> ros;        // default-partition publisher / subscriber (ROS side)
  std::unique_ptr<RosInbound> inbound;    // options.inbound
  std::unique_ptr<RosOutbound> outbound;  // options.outbound
  std::unique_ptr<RosWriter<ParticipantEntitiesInfoPubSubType<RosDistro::kHumble>>> graph_humble;
  std::unique_ptr<RosWriter<ParticipantEntitiesInfoPubSubType<RosDistro::kJazzy>>> graph_jazzy;
  std::unique_ptr<dds::Reader<msg::CameraPosePubSubType>> pose_reader;
  std::unique_ptr<dds::Reader<msg::StreamStatusPubSubType>> status_reader;

  Impl(std::shared_ptr<dds::Participant> p, std::shared_ptr<dds::Participant> r,
       const RosBridgeOptions& o)
      : participant(std::move(p)), ros_participant(std::move(r)), options(o) {}

  void Start() {
    ros = RosSession::Create(ros_participant);
    if (options.inbound) inbound = std::make_unique<RosInbound>(participant, ros, options);
    if (options.outbound) {
      RosInbound* in = inbound.get();
      outbound = std::make_unique<RosOutbound>(participant, ros, options, [in] {
        return in != nullptr ? in->image_frame_id() : std::string();
      });
    }
    // Writers first, then the threads, then the readers (their callbacks need both).
    for (RosHalf* half : Halves()) half->CreateWriters();
    for (RosHalf* half : Halves()) half->StartThread();
    pose_reader = std::make_unique<dds::Reader<msg::CameraPosePubSubType>>(
        participant, dds::topics::kCameraPose, dds::TopicKind::kCameraPose,
        [this](msg::CameraPose&& m) {
          if (inbound) inbound->Acknowledge(m.header().seq());
          if (outbound) outbound->PublishPose(std::move(m));
        });
    status_reader = std::make_unique<dds::Reader<msg::StreamStatusPubSubType>>(
        participant, dds::topics::kStreamStatus, dds::TopicKind::kStreamStatus,
        [this](msg::StreamStatus&& s) {
          if (s.kind() == static_cast<uint8_t>(StreamEvent::kReady) && inbound) {
            inbound->ComponentReady(s.source());
          }
          if (s.kind() == static_cast<uint8_t>(StreamEvent::kComponentDone)) {
            std::lock_guard<std::mutex> lock(mutex);
            if (s.source() == "slam") slam_done = true;
            if (s.source() == "mapper") mapper_done = true;
          }
        });
    for (RosHalf* half : Halves(/*outbound_first=*/true)) half->CreateReaders();
    AnnounceNode();
  }

  // The halves there are, inbound first (or outbound first).
  std::vector<RosHalf*> Halves(bool outbound_first = false) const {
    std::vector<RosHalf*> halves;
    if (inbound) halves.push_back(inbound.get());
    if (outbound) halves.insert(outbound_first ? halves.begin() : halves.end(), outbound.get());
    return halves;
  }

  // The ROS 2 graph entry: one node owning the ROS readers and writers (ros2_graph.h).
  void AnnounceNode() {
    std::lock_guard<std::mutex> lock(mutex);
    graph.participant = ToGuid(ros_participant->get()->guid());
    if (!options.announce_node) return;
    RosNodeEntities node;
    node.node_namespace = options.node_namespace;
    node.node_name = options.node_name;
    if (inbound) {
      for (const auto& guid : inbound->ros_reader_guids()) node.readers.push_back(ToGuid(guid));
    }
    if (outbound) {
      for (const auto& guid : outbound->ros_writer_guids()) node.writers.push_back(ToGuid(guid));
    }
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
    // Readers first (no callback after this), then the threads (the outbound one runs the jobs
    // still queued).
    for (RosHalf* half : Halves()) half->StopReaders();
    pose_reader.reset();
    status_reader.reset();
    for (RosHalf* half : Halves()) half->StopThread();
    // Let reliable readers receive the last samples before the writers go away.
    for (RosHalf* half : Halves(/*outbound_first=*/true))
      half->WaitForAcknowledgments(std::chrono::milliseconds(1000));
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
  if (impl_->options.end_of_stream_on_stop && impl_->inbound) {
    EndInput();
    impl_->inbound->WaitForEndOfStream(std::chrono::seconds(2));
  }
  impl_->Stop();
}

void RosBridge::EndInput() {
  if (impl_->inbound) impl_->inbound->EndInput();
}

bool RosBridge::slam_done() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->slam_done;
}

bool RosBridge::outputs_done() const {
  const bool mapper_running = impl_->outbound && impl_->outbound->map_writer_matched();
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->slam_done && (impl_->mapper_done || !mapper_running);
}

int RosBridge::matched_ros_writers() const {
  return impl_->outbound ? impl_->outbound->matched_ros_writers() : 0;
}

int RosBridge::matched_pipeline_topics() const {
  if (!impl_->outbound) return 0;
  const bool poses = impl_->pose_reader && impl_->pose_reader->matched() > 0;
  return (poses ? 1 : 0) + impl_->outbound->matched_pipeline_topics();
}

RosBridgeStats RosBridge::stats() const {
  RosBridgeStats s;
  if (impl_->inbound) s = impl_->inbound->stats();
  if (impl_->outbound) {
    const RosBridgeStats out = impl_->outbound->stats();
    s.poses = out.poses;
    s.paths = out.paths;
    s.transforms = out.transforms;
    s.detections = out.detections;
    s.maps = out.maps;
    s.bad_pipeline_samples = out.bad_pipeline_samples;
  }
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
