// dygslam bridge: the ROS 2 bridge (bridge/ros2_bridge.h) on the pipeline's DDS domain, optionally
// with the SLAM components in the same process (--run-slam): a ROS 2 camera driver in, pose /
// path / odometry / TF / detections / OctoMap out. SIGINT / SIGTERM stop it (the components
// flush their outputs).
// Compiled only when the bridge is built (dygslam_bridge defines DYGSLAM_HAVE_BRIDGE).
#ifdef DYGSLAM_HAVE_BRIDGE
#include <algorithm>
#include <memory>

#include "apps/command.h"
#include "bridge/bridge_session.h"
#include "components/dds/participant.h"
#include "components/dds/qos.h"
#include "components/pipeline.h"
#include "core/base/error.h"
#include "core/config/settings.h"
#include "run/run_settings.h"

namespace dygslam::cli {
namespace {

int RunBridgeCommand(const std::vector<std::string>& args) {
  ArgParser p(
      "bridge", "[--preset realsense] [--run-slam --config FILE] [--domain N] [options]",
      "ROS 2 bridge: subscribes to a ROS 2 camera (colour + aligned depth + CameraInfo) and\n"
      "feeds the pipeline; republishes pose, path, odometry, TF, detections and the OctoMap\n"
      "as ROS 2 topics (ROS 2 type names, QoS and topic conventions; no ROS 2 needed).\n"
      "Use the ROS_DOMAIN_ID of the robot as --domain.");
  ros2::RosBridgeOptions d;
  p.AddOption("domain", "N", "DDS domain id = ROS_DOMAIN_ID (default DYGSLAM_DOMAIN_ID or 0)",
              "-1");
  p.AddOption("partition", "NAME",
              "DDS partition of the pipeline's topics (as `dygslam component ... --partition`);\n"
              "the ROS 2 topics stay in the default partition (default: none)");
  p.AddOption("wait-for", "NAMES",
              "comma-separated components whose start announcement the bridge waits for before\n"
              "forwarding the first frame (default: slam; with --run-slam: the ones it runs)",
              "slam");
  p.AddOption("preset", "NAME",
              "camera topics: realsense | realsense-legacy | azure-kinect | kinect", "realsense");
  p.AddOption("color-topic", "TOPIC", "colour sensor_msgs/Image (overrides the preset)");
  p.AddOption("depth-topic", "TOPIC", "depth aligned to colour, 16UC1 mm or 32FC1 m");
  p.AddOption("camera-info-topic", "TOPIC", "colour sensor_msgs/CameraInfo");
  p.AddOption("depth-unit", "M",
              "metres per 16UC1 depth count (0.001 = millimetres, the ROS convention;\n"
              "e.g. 0.00025 for cameras counting quarter millimetres)",
              "0.001");
  p.AddOption("max-stamp-diff", "S", "colour/depth pairing tolerance (s)", "0.02");
  p.AddOption("window", "N", "frames in flight to slam (back-pressure)", "2");
  p.AddOption("max-pending", "N",
              "synchronised frames waiting for slam before the oldest is dropped", "2");
  p.AddOption("eos-idle", "S", "end the stream after S seconds without frames (0 = never)", "0");
  p.AddOption("pose-topic", "TOPIC", "geometry_msgs/PoseStamped", d.pose_topic);
  p.AddOption("odom-topic", "TOPIC", "nav_msgs/Odometry", d.odom_topic);
  p.AddOption("path-topic", "TOPIC", "nav_msgs/Path", d.path_topic);
  p.AddOption("tf-topic", "TOPIC", "tf2_msgs/TFMessage", d.tf_topic);
  p.AddOption("tf-static-topic", "TOPIC", "tf2_msgs/TFMessage (transient local)",
              d.tf_static_topic);
  p.AddOption("detections-topic", "TOPIC", "vision_msgs/Detection2DArray", d.detections_topic);
  p.AddOption("octomap-topic", "TOPIC", "octomap_msgs/Octomap (binary)", d.octomap_topic);
  p.AddOption("map-frame", "FRAME", "fixed frame of pose / path / odometry / TF", d.map_frame);
  p.AddOption("world-frame", "FRAME", "SLAM world frame (OctoMap), static TF from map",
              d.world_frame);
  p.AddOption("camera-frame", "FRAME", "TF child frame of the camera (optical axes)",
              d.camera_frame);
  p.AddOption("image-frame", "FRAME", "frame of the detections (default: the images' frame_id)");
  p.AddOption("path-every", "N", "publish the online path every N poses", "10");
  p.AddOption("node-name", "NAME", "ROS 2 node name shown by `ros2 node list`", d.node_name);
  p.AddOption("node-namespace", "NS", "ROS 2 node namespace", d.node_namespace);
  p.AddOption("ros-distro", "NAME",
              "ROS 2 distribution of the peers: humble | jazzy (iron, kilted, rolling as jazzy);\n"
              "sets the layout of ros_discovery_info",
              "jazzy");
  p.AddFlag("no-node", "do not announce a ROS 2 node (ros_discovery_info)");
  p.AddFlag("ros-no-shm",
            "ROS 2 side over UDP only (no shared memory; containers without ipc: host)");
  p.AddFlag("ros-loopback",
            "ROS 2 side on the pipeline's participant (shared memory + 127.0.0.1 only)");
  p.AddFlag("no-ros-axes", "map = SLAM world axes (optical: z forward) instead of REP 103");
  p.AddFlag("no-tf", "do not publish /tf");
  p.AddFlag("no-inbound", "outbound only (the frames come from elsewhere, e.g. the player)");
  p.AddFlag("no-outbound", "inbound only");
  p.AddFlag("run-slam", "also run the detector, slam, mapper and recorder components here");
  p.AddOption("config", "FILE",
              "--run-slam: settings YAML (camera intrinsics must match CameraInfo)");
  p.AddOption("filter", "MODE", "--run-slam: none | boxes | geometry | paper | full", "full");
  p.AddOption("out", "DIR", "--run-slam: output folder (trajectory, map.bt)", "out/bridge");
  p.AddFlag("no-mapper", "--run-slam: no mapper component");
  if (!p.Parse(args)) return p.exit_code();

  ros2::RosBridgeOptions o;
  o.ApplyCameraPreset(p.Get("preset"));
  if (p.Has("color-topic")) o.color_topic = p.Get("color-topic");
  if (p.Has("depth-topic")) o.depth_topic = p.Get("depth-topic");
  if (p.Has("camera-info-topic")) o.camera_info_topic = p.Get("camera-info-topic");
  int max_pending = 0, domain = -1;
  if (!p.GetNumber("depth-unit", 0, 1000, &o.depth_unit) ||
      !p.GetNumber("max-stamp-diff", 0, 1000, &o.max_stamp_difference_s) ||
      !p.GetInt("window", 0, dds::kFrameHistoryDepth - 1, &o.window) ||
      !p.GetInt("max-pending", 1, 1000000, &max_pending) ||
      !p.GetNumber("eos-idle", 0, 1e9, &o.end_of_stream_idle_s) ||
      !p.GetInt("path-every", 0, 1000000, &o.path_every) || !p.GetInt("domain", -1, 232, &domain))
    return p.exit_code();
  // A depth unit of 0 would turn every depth into 0 m (no depth at all): a usage error naming the
  // option typed, like the other ranges above.
  if (!(o.depth_unit > 0))
    return p.UsageError("--depth-unit " + p.Get("depth-unit") +
                        ": must be > 0 (metres per depth unit, e.g. 0.001 for millimetres)");
  o.max_pending_frames = static_cast<size_t>(max_pending);
  o.pose_topic = p.Get("pose-topic");
  o.odom_topic = p.Get("odom-topic");
  o.path_topic = p.Get("path-topic");
  o.tf_topic = p.Get("tf-topic");
  o.tf_static_topic = p.Get("tf-static-topic");
  o.detections_topic = p.Get("detections-topic");
  o.octomap_topic = p.Get("octomap-topic");
  o.map_frame = p.Get("map-frame");
  o.world_frame = p.Get("world-frame");
  o.camera_frame = p.Get("camera-frame");
  o.image_frame = p.Get("image-frame");
  o.ros_axes = !p.Flag("no-ros-axes");
  o.publish_tf = !p.Flag("no-tf");
  o.inbound = !p.Flag("no-inbound");
  o.outbound = !p.Flag("no-outbound");
  o.node_name = p.Get("node-name");
  o.node_namespace = p.Get("node-namespace");
  ros2::CheckNodeName(o.node_name, "--node-name");
  ros2::CheckNodeNamespace(o.node_namespace, "--node-namespace");
  o.ros_distro = ros2::ParseRosDistro(p.Get("ros-distro"), "--ros-distro");
  o.announce_node = !p.Flag("no-node");
  o.wait_for_components.clear();
  {
    const std::string list = p.Get("wait-for");
    size_t begin = 0;
    while (begin <= list.size()) {
      const size_t end = std::min(list.find(',', begin), list.size());
      if (end > begin) o.wait_for_components.push_back(list.substr(begin, end - begin));
      begin = end + 1;
    }
  }
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
    pipeline.system = LoadRunConfiguration(
                          {pipeline.settings_path, CliSettingsReadOptions(false), p.Get("filter")})
                          .system;
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
