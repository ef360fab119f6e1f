// dygslam bridge: the ROS 2 bridge (bridge/ros2_bridge.h), optionally with the SLAM components
// in the same process (--run-slam): a ROS 2 camera in; pose, path, odometry, TF, detections and
// OctoMap out. Compiled only with the bridge (dygslam_bridge defines DYGSLAM_HAVE_BRIDGE).
#ifdef DYGSLAM_HAVE_BRIDGE
#include <memory>

#include "apps/command.h"
#include "bridge/bridge_session.h"
#include "components/dds/participant.h"
#include "components/dds/qos.h"
#include "components/pipeline.h"

namespace dygslam::cli {
namespace {

// The bridge's topics, frames and node name: each an option whose default is the bridge's (the
// camera's topics: the --preset's, replaced only when given).
struct NameOption {
  const char* option;
  const char* meta;
  const char* doc;
  std::string ros2::RosBridgeOptions::*field;
  bool from_preset = false;
};
using B = ros2::RosBridgeOptions;
const NameOption kNameOptions[] = {
    {"color-topic", "TOPIC", "colour sensor_msgs/Image (overrides the preset)", &B::color_topic,
     true},
    {"depth-topic", "TOPIC", "depth aligned to colour, 16UC1 mm or 32FC1 m", &B::depth_topic, true},
    {"camera-info-topic", "TOPIC", "colour sensor_msgs/CameraInfo", &B::camera_info_topic, true},
    {"pose-topic", "TOPIC", "geometry_msgs/PoseStamped", &B::pose_topic},
    {"odom-topic", "TOPIC", "nav_msgs/Odometry", &B::odom_topic},
    {"path-topic", "TOPIC", "nav_msgs/Path", &B::path_topic},
    {"tf-topic", "TOPIC", "tf2_msgs/TFMessage", &B::tf_topic},
    {"tf-static-topic", "TOPIC", "tf2_msgs/TFMessage (transient local)", &B::tf_static_topic},
    {"detections-topic", "TOPIC", "vision_msgs/Detection2DArray", &B::detections_topic},
    {"octomap-topic", "TOPIC", "octomap_msgs/Octomap (binary)", &B::octomap_topic},
    {"map-frame", "FRAME", "fixed frame of pose / path / odometry / TF", &B::map_frame},
    {"world-frame", "FRAME", "SLAM world frame (OctoMap), static TF from map", &B::world_frame},
    {"camera-frame", "FRAME", "TF child frame of the camera (optical axes)", &B::camera_frame},
    {"image-frame", "FRAME", "frame of the detections (default: the images' frame_id)",
     &B::image_frame},
    {"node-name", "NAME", "ROS 2 node name shown by `ros2 node list`", &B::node_name},
    {"node-namespace", "NS", "ROS 2 node namespace", &B::node_namespace}};

// The options of `dygslam bridge`; those bound to a field of `o` are read by ReadBound().
void DefineBridgeOptions(ArgParser* parser, ros2::RosBridgeOptions* o) {
  ArgParser& p = *parser;
  p.AddOption("domain", "N", "DDS domain id = ROS_DOMAIN_ID (default DYGSLAM_DOMAIN_ID or 0)",
              "-1");
  p.AddOption("partition", "NAME",
              "DDS partition of the pipeline's topics (the ROS 2 topics stay in the default one)");
  p.AddOption("wait-for", "NAMES",
              "components (comma-separated) announced before the first frame is forwarded", "slam");
  p.AddOption("preset", "NAME",
              "camera topics: realsense | realsense-legacy | azure-kinect | kinect", "realsense");
  p.Bind("depth-unit", "M", "metres per 16UC1 depth count (0.001: millimetres, ROS)",
         &o->depth_unit, 0, 1000);
  p.Bind("max-stamp-diff", "S", "colour/depth pairing tolerance (s)", &o->max_stamp_difference_s, 0,
         1000);
  p.Bind("window", "N", "frames in flight to slam (back-pressure)", &o->window, 0,
         dds::kFrameHistoryDepth - 1);
  p.AddOption("max-pending", "N",
              "synchronised frames waiting for slam before the oldest is dropped", "2");
  p.Bind("eos-idle", "S", "end the stream after S seconds without frames (0 = never)",
         &o->end_of_stream_idle_s, 0, 1e9);
  for (const NameOption& n : kNameOptions)
    p.AddOption(n.option, n.meta, n.doc, n.from_preset ? "" : o->*n.field);
  p.Bind("path-every", "N", "publish the online path every N poses", &o->path_every, 0, 1000000);
  p.AddOption("ros-distro", "NAME", "ROS 2 of the peers: humble | jazzy (iron, kilted, rolling)",
              "jazzy");
  p.BindFlag("no-node", "do not announce a ROS 2 node (ros_discovery_info)", &o->announce_node,
             false);
  p.AddFlag("ros-no-shm", "ROS 2 side over UDP only (containers without ipc: host)");
  p.AddFlag("ros-loopback", "ROS 2 side on the pipeline's participant (shm + 127.0.0.1 only)");
  p.BindFlag("no-ros-axes", "map = SLAM world axes (optical: z forward) instead of REP 103",
             &o->ros_axes, false);
  p.BindFlag("no-tf", "do not publish /tf", &o->publish_tf, false);
  p.BindFlag("no-inbound", "outbound only (the frames come from elsewhere, e.g. the player)",
             &o->inbound, false);
  p.BindFlag("no-outbound", "inbound only", &o->outbound, false);
  p.AddFlag("run-slam", "also run the detector, slam, mapper and recorder components here");
  p.AddOption("config", "FILE", "--run-slam: settings YAML (intrinsics as in CameraInfo)");
  p.AddOption("filter", "MODE", "--run-slam: none | boxes | geometry | paper | full", "full");
  p.AddOption("out", "DIR", "--run-slam: output folder (trajectory, map.bt)", "out/bridge");
  p.AddFlag("no-mapper", "--run-slam: no mapper component");
}

int RunBridgeCommand(const std::vector<std::string>& args) {
  ArgParser p("bridge", "[--preset realsense] [--run-slam --config FILE] [--domain N] [options]",
              "ROS 2 bridge: a ROS 2 camera (colour + aligned depth + CameraInfo) in; pose, path,\n"
              "odometry, TF, detections and the OctoMap out as ROS 2 topics (no ROS 2 needed).\n"
              "Use the ROS_DOMAIN_ID of the robot as --domain.");
  ros2::RosBridgeOptions o;  // its defaults are the options' defaults
  DefineBridgeOptions(&p, &o);
  if (!p.Parse(args)) return p.exit_code();

  o.ApplyCameraPreset(p.Get("preset"));
  int max_pending = 0, domain = -1;
  if (!p.ReadBound() || !p.GetInt("max-pending", 1, 1000000, &max_pending) ||
      !p.GetInt("domain", -1, 232, &domain))
    return p.exit_code();
  // A depth unit of 0 would turn every depth into 0 m (no depth at all): a usage error naming the
  // option typed, like the other ranges above.
  if (!(o.depth_unit > 0))
    return p.UsageError("--depth-unit " + p.Get("depth-unit") +
                        ": must be > 0 (metres per depth unit, e.g. 0.001 for millimetres)");
  o.max_pending_frames = static_cast<size_t>(max_pending);
  for (const NameOption& n : kNameOptions)
    if (!n.from_preset || p.Has(n.option)) o.*n.field = p.Get(n.option);
  ros2::CheckNodeName(o.node_name, "--node-name");
  ros2::CheckNodeNamespace(o.node_namespace, "--node-namespace");
  o.ros_distro = ros2::ParseRosDistro(p.Get("ros-distro"), "--ros-distro");
  o.wait_for_components = p.GetList("wait-for");
  const std::string partition = p.Get("partition");
  o.Check();

  if (domain < 0) domain = dds::DomainIdFromEnvironment(0);

  ros2::BridgeSessionOptions session;
  if (p.Flag("run-slam")) {
    if (!p.Has("config")) return p.UsageError("--run-slam needs --config FILE");
    PipelineOptions pipeline;
    pipeline.dataset_dir = "-";
    pipeline.settings_path = p.Get("config");
    pipeline.output_dir = PrepareOutputDir("out", p.Get("out")).string();
    pipeline.system = LoadCommandSettings(p, pipeline.settings_path).system;
    pipeline.run_mapper = !p.Flag("no-mapper");
    pipeline.domain_id = domain;
    pipeline.partition = partition;
    pipeline.Check();
    session.components = pipeline;
  }

  session.bridge = o;
  session.domain_id = domain;
  session.partition = partition;
  session.wait_for_given = p.Has("wait-for");
  session.ros_on_pipeline_participant = p.Flag("ros-loopback");
  session.ros_shared_memory = !p.Flag("ros-no-shm");
  return ros2::RunBridgeSession(std::move(session),
                                std::make_shared<StopFlag>(StopFlag::Signals::kStop));
}

const CommandRegistrar kRegistrar({"bridge", "ROS 2 bridge (camera in; pose, path, TF, map out)",
                                   RunBridgeCommand});

}  // namespace
}  // namespace dygslam::cli
#endif  // DYGSLAM_HAVE_BRIDGE
