// ROS 2 interop of the bridge with a second DDS implementation (Cyclone DDS, C API, types from
// the same ROS 2 IDL, ROS 2 type names) as the ROS 2 stand-in, on the shared Bonn frames.
// Runs inside run_in_netns.sh (loopback only); distinct domain ids per test.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <map>
#include <mutex>
#include <opencv2/core.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include "bridge/ros2_bridge.h"
#include "bridge/tests/cyclone_peer.h"
#include "bridge/tests/interop_support.h"
#include "components/convert.h"
#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "components/dds/qos.h"
#include "components/pipeline.h"
#include "core/config/settings.h"
#include "core/eval/trajectory_eval.h"
#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "core/system/system.h"
#include "dygslam_msg/CameraPosePubSubTypes.h"
#include "dygslam_msg/DetectionsPubSubTypes.h"
#include "dygslam_msg/MapUpdatePubSubTypes.h"
#include "dygslam_msg/TrajectoryPubSubTypes.h"
#include "run/settings_table.h"
#include "run/system_config.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {

using testing::CyclonePeer;
using testing::PeerPose;
using testing::WaitUntil;

std::shared_ptr<dds::Participant> MakeParticipant(int domain, const std::string& name,
                                                  const std::string& partition = "") {
  dds::ParticipantOptions o;
  o.domain_id = domain;
  o.name = name;
  o.partition = partition;
  o.use_xml_profile = false;
  return dds::Participant::Create(o);
}

// REP 103 map axes from the optical SLAM world axes, written out independently of the bridge.
Rigid3d MapFromWorld() {
  Eigen::Matrix3d r;
  r << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  return Rigid3d(r, Eigen::Vector3d::Zero());
}

void ExpectPoseEq(const PeerPose& got, const Rigid3d& expected, const std::string& what) {
  EXPECT_NEAR(got.position[0], expected.translation.x(), 1e-9) << what;
  EXPECT_NEAR(got.position[1], expected.translation.y(), 1e-9) << what;
  EXPECT_NEAR(got.position[2], expected.translation.z(), 1e-9) << what;
  const Eigen::Quaterniond q(got.orientation[3], got.orientation[0], got.orientation[1],
                             got.orientation[2]);
  EXPECT_NEAR(std::abs(q.dot(expected.rotation.normalized())), 1.0, 1e-9) << what;
}

// Outbound: a Cyclone peer subscribed with ROS 2 type names receives pose, odometry, path, TF,
// detections and the map of a dataset run, with the values the pipeline produced (read from the
// pipeline's own topics with Fast DDS at the same time). The run is in its own DDS partition (as
// `dygslam run`'s): the bridge follows it on the pipeline side, while the ROS 2 peer (no
// partition) still sees the bridge's ROS topics.
TEST(Interop, CyclonePeerReceivesWhatThePipelineProduced) {
  DYGSLAM_REQUIRE_DATASET(dataset, "bonn_crowd_part");
  const std::string tmp = dygslam::testing::MakeTempDir("bridge_outbound");
  const int domain = 171;
  const std::string partition = "bridge_interop_171";

  CyclonePeer peer(domain);
  peer.Subscribe({});

  std::mutex mutex;
  std::map<int64_t, msg::CameraPose> ref_poses;  // by stamp (ns), tracked frames only
  std::map<int64_t, msg::Detections> ref_detections;
  std::vector<msg::MapUpdate> ref_maps;
  std::optional<msg::Trajectory> ref_trajectory;
  auto ref = MakeParticipant(domain, "test_reference", partition);
  auto stamp_ns = [](const msg::Time& t) { return int64_t{t.sec()} * 1000000000 + t.nanosec(); };
  dds::Reader<msg::CameraPosePubSubType> pose_reader(
      ref, dds::topics::kCameraPose, dds::TopicKind::kCameraPose, [&](msg::CameraPose&& m) {
        if (!m.has_pose()) return;
        std::lock_guard<std::mutex> lock(mutex);
        ref_poses[stamp_ns(m.header().stamp())] = m;
      });
  dds::Reader<msg::DetectionsPubSubType> det_reader(
      ref, dds::topics::kDetections, dds::TopicKind::kDetections, [&](msg::Detections&& m) {
        std::lock_guard<std::mutex> lock(mutex);
        ref_detections[stamp_ns(m.header().stamp())] = m;
      });
  dds::Reader<msg::MapUpdatePubSubType> map_reader(
      ref, dds::topics::kMapUpdate, dds::TopicKind::kMapUpdate, [&](msg::MapUpdate&& m) {
        std::lock_guard<std::mutex> lock(mutex);
        ref_maps.push_back(m);
      });
  dds::Reader<msg::TrajectoryPubSubType> trajectory_reader(
      ref, dds::topics::kTrajectory, dds::TopicKind::kTrajectory, [&](msg::Trajectory&& m) {
        if (m.keyframes_only()) return;
        std::lock_guard<std::mutex> lock(mutex);
        ref_trajectory = m;
      });

  ros2::RosBridgeOptions options;
  options.inbound = false;
  ros2::RosBridge bridge(MakeParticipant(domain, "test_bridge", partition), options);
  // Discovery across implementations, both ways, before the first sample: the peer's 7 readers
  // matched the bridge's 7 writers AND each bridge writer matched the peer's reader. The ROS
  // topics are volatile: a sample written before its writer matched the reader is not delivered
  // (once it failed with 43 of 44 detections when only the peer's side had been waited for).
  ASSERT_TRUE(
      WaitUntil([&] { return peer.MatchedWriters() >= 7 && bridge.matched_ros_writers() == 7; },
                std::chrono::seconds(15)))
      << "the peer matched " << peer.MatchedWriters() << " of 7 bridge writers; "
      << bridge.matched_ros_writers() << " of 7 bridge writers matched the peer";

  PipelineOptions po;
  po.dataset_dir = dataset;
  po.output_dir = tmp + "/run";
  po.system = SystemOptionsFromSettings(LoadSettings(testing::BonnSettingsPath()));
  po.system.deterministic = true;
  po.first_entry = 100;  // people walk through from frame ~110
  po.last_entry = 150;
  po.domain_id = domain;
  po.partition = partition;
  po.wait_for_components = true;  // the player waits for the others' READY
  std::filesystem::create_directories(po.output_dir);
  // The pipeline's components on threads, the player last: frames flow only once this test's
  // readers and the bridge have discovered the pipeline's writers. The detector's writer ends
  // with the stream, before slam's, and its transient-local history holds the last 32 samples:
  // a reader that discovers the pipeline only at its next participant announcement (seconds
  // later on a loaded machine) would get no detections at all (seen once in CI).
  testing::ComponentThreads components(po, {"recorder", "slam", "detector", "mapper"});
  ASSERT_TRUE(WaitUntil(
      [&] {
        return pose_reader.matched() > 0 && det_reader.matched() > 0 && map_reader.matched() > 0 &&
               trajectory_reader.matched() > 0 && bridge.matched_pipeline_topics() == 4;
      },
      std::chrono::seconds(20)))
      << "test readers matched: pose " << pose_reader.matched() << ", detections "
      << det_reader.matched() << ", map " << map_reader.matched() << ", trajectory "
      << trajectory_reader.matched() << "; bridge: " << bridge.matched_pipeline_topics()
      << " of 4 pipeline topics";
  ASSERT_EQ(RunComponent("player", po, std::make_shared<StopFlag>()), 0);
  components.Finish();
  for (const std::string& name : components.names()) {
    EXPECT_EQ(components.code(name), 0) << name;
  }

  // Everything the pipeline published reaches the peer.
  auto complete = [&] {
    peer.Poll();
    std::lock_guard<std::mutex> lock(mutex);
    return ref_trajectory && !ref_maps.empty() && peer.poses.size() >= ref_poses.size() &&
           peer.detections.size() >= ref_detections.size() && !peer.maps.empty() &&
           peer.maps.back().stamp_ns == stamp_ns(ref_maps.back().header().stamp()) &&
           !peer.paths.empty() && peer.paths.back().poses.size() == ref_trajectory->poses().size();
  };
  EXPECT_TRUE(WaitUntil(complete, std::chrono::seconds(20)));
  std::lock_guard<std::mutex> lock(mutex);
  const Rigid3d map_from_world = MapFromWorld();

  // Pose + TF + odometry: one each per tracked frame, equal to map_from_world * world_from_cam.
  ASSERT_GT(ref_poses.size(), 40u);
  ASSERT_EQ(peer.poses.size(), ref_poses.size());
  ASSERT_EQ(peer.transforms.size(), ref_poses.size());
  ASSERT_EQ(peer.odometry.size(), ref_poses.size());
  for (size_t i = 0; i < peer.poses.size(); ++i) {
    const PeerPose& p = peer.poses[i];
    ASSERT_TRUE(ref_poses.count(p.stamp_ns)) << "pose with an unknown stamp " << p.stamp_ns;
    const Rigid3d expected =
        map_from_world * PoseFromMsg(ref_poses.at(p.stamp_ns).world_from_cam(), "ref");
    EXPECT_EQ(p.frame_id, "map");
    ExpectPoseEq(p, expected, "pose " + std::to_string(i));
    const auto& tf = peer.transforms[i];
    EXPECT_EQ(tf.pose.frame_id, "map");
    EXPECT_EQ(tf.child_frame_id, "dygslam_camera");
    ASSERT_TRUE(ref_poses.count(tf.pose.stamp_ns));
    ExpectPoseEq(tf.pose,
                 map_from_world * PoseFromMsg(ref_poses.at(tf.pose.stamp_ns).world_from_cam(), "r"),
                 "tf " + std::to_string(i));
    EXPECT_EQ(peer.odometry[i].child_frame_id, "dygslam_camera");
    ExpectPoseEq(
        peer.odometry[i].pose,
        map_from_world *
            PoseFromMsg(ref_poses.at(peer.odometry[i].pose.stamp_ns).world_from_cam(), "r"),
        "odometry " + std::to_string(i));
  }
  // A moving camera has a non-zero odometry twist somewhere.
  double max_speed = 0;
  for (const auto& o : peer.odometry) {
    max_speed = std::max(max_speed, std::hypot(o.linear[0], o.linear[1], o.linear[2]));
  }
  EXPECT_GT(max_speed, 0.01);

  // /tf_static: map -> SLAM world (transient local).
  ASSERT_GE(peer.static_transforms.size(), 1u);
  EXPECT_EQ(peer.static_transforms[0].pose.frame_id, "map");
  EXPECT_EQ(peer.static_transforms[0].child_frame_id, "dygslam_world");
  ExpectPoseEq(peer.static_transforms[0].pose, map_from_world, "tf_static");

  // Path: online paths while running, then the final refined trajectory.
  ASSERT_TRUE(ref_trajectory);
  ASSERT_GE(peer.paths.size(), 2u);
  const auto& final_path = peer.paths.back();
  ASSERT_EQ(final_path.poses.size(), ref_trajectory->poses().size());
  EXPECT_EQ(final_path.frame_id, "map");
  for (size_t i = 0; i < final_path.poses.size(); ++i) {
    const auto& r = ref_trajectory->poses()[i];
    EXPECT_EQ(final_path.poses[i].stamp_ns, stamp_ns(r.stamp()));
    ExpectPoseEq(final_path.poses[i], map_from_world * PoseFromMsg(r.world_from_cam(), "ref"),
                 "path pose " + std::to_string(i));
  }

  // Detections: same boxes as the detector component's, centre + size, class name, score.
  // One Detections message per frame the detector runs on (Detector.every_n_frames).
  const size_t every_n = static_cast<size_t>(po.system.detection_every_n_frames);
  ASSERT_EQ(ref_detections.size(), (50u + every_n - 1) / every_n)
      << "one Detections message per detector frame";
  ASSERT_EQ(peer.detections.size(), ref_detections.size());
  size_t boxes = 0;
  for (const auto& d : peer.detections) {
    ASSERT_TRUE(ref_detections.count(d.stamp_ns));
    const auto& r = ref_detections.at(d.stamp_ns).detections();
    ASSERT_EQ(d.boxes.size(), r.size());
    for (size_t k = 0; k < r.size(); ++k) {
      EXPECT_DOUBLE_EQ(d.boxes[k].center_x, r[k].x() + r[k].w() * 0.5);
      EXPECT_DOUBLE_EQ(d.boxes[k].center_y, r[k].y() + r[k].h() * 0.5);
      EXPECT_DOUBLE_EQ(d.boxes[k].size_x, r[k].w());
      EXPECT_DOUBLE_EQ(d.boxes[k].size_y, r[k].h());
      EXPECT_EQ(d.boxes[k].class_id, r[k].label());
      EXPECT_DOUBLE_EQ(d.boxes[k].score, r[k].score());
      ++boxes;
    }
  }
  EXPECT_GT(boxes, 10u) << "people walk through frames 110-150";

  // OctoMap: the newest map, readable as octomap_msgs::binaryMsgToMap does, equal to the
  // mapper's octree.
  const auto& map = peer.maps.back();
  EXPECT_TRUE(map.binary);
  EXPECT_EQ(map.id, "OcTree");
  EXPECT_EQ(map.frame_id, "dygslam_world");
  const msg::MapUpdate& ref_map = ref_maps.back();
  std::istringstream bt(std::string(ref_map.octree_bt().begin(), ref_map.octree_bt().end()));
  octomap::OcTree ref_tree(0.1);
  ASSERT_TRUE(ref_tree.readBinary(bt));
  EXPECT_DOUBLE_EQ(map.resolution, ref_tree.getResolution());
  octomap::OcTree tree(map.resolution);
  std::stringstream data;
  data.write(reinterpret_cast<const char*>(map.data.data()), map.data.size());
  tree.readBinaryData(data);
  EXPECT_GT(tree.getNumLeafNodes(), 100u);
  EXPECT_EQ(tree.getNumLeafNodes(), ref_tree.getNumLeafNodes());
  size_t occupied = 0, same = 0;
  for (auto it = ref_tree.begin_leafs(); it != ref_tree.end_leafs(); ++it) {
    if (!ref_tree.isNodeOccupied(*it)) continue;
    ++occupied;
    const octomap::OcTreeNode* n = tree.search(it.getKey(), it.getDepth());
    if (n != nullptr && tree.isNodeOccupied(n)) ++same;
  }
  EXPECT_GT(occupied, 0u);
  EXPECT_EQ(same, occupied);

  const ros2::RosBridgeStats s = bridge.stats();
  EXPECT_EQ(s.bad_pipeline_samples, 0u);
}

// Inbound: a Cyclone peer publishing sensor_msgs/Image colour (rgb8) + depth (16UC1 mm) and
// CameraInfo from the Bonn frames drives slam through the bridge (the components as in the
// pipeline, without the player) to a trajectory whose ATE is within 10 % of the direct run of
// the System on the same frames.
TEST(Interop, CameraOverRos2DrivesSlamLikeTheDirectRun) {
  DYGSLAM_REQUIRE_DATASET(dataset_dir, "bonn_crowd_part");
  const std::string tmp = dygslam::testing::MakeTempDir("bridge_inbound");
  const int domain = 172;
  const size_t kFrames = 100;

  const testing::DirectReference reference = testing::RunDirectReference(dataset_dir, kFrames);
  const SystemOptions& options = reference.options;
  const RgbdDataset& dataset = reference.dataset;
  const std::vector<StampedPose>& groundtruth = reference.groundtruth;
  const std::vector<size_t>& indices = reference.indices;
  const double direct_ate = reference.ate;

  // Through ROS 2: components on threads, the bridge, the Cyclone camera.
  const PipelineOptions po = testing::BridgeFedPipeline(options, tmp + "/bridge", domain);
  testing::ComponentThreads components(po);
  std::mutex mutex;

  std::set<int64_t> acknowledged;  // stamps slam has answered (CameraPose)
  // Figures for BENCHMARKS.md (printed, not asserted): per frame, publish -> CameraPose round
  // trip and the detector's / slam's own times.
  struct Timing {
    std::chrono::steady_clock::time_point answered;
    double detection_ms = 0, total_ms = 0;
  };
  std::map<int64_t, Timing> timings;
  auto ref = MakeParticipant(domain, "test_acks");
  dds::Reader<msg::CameraPosePubSubType> acks(
      ref, dds::topics::kCameraPose, dds::TopicKind::kCameraPose, [&](msg::CameraPose&& m) {
        const auto now = std::chrono::steady_clock::now();
        const int64_t stamp =
            int64_t{m.header().stamp().sec()} * 1000000000 + m.header().stamp().nanosec();
        std::lock_guard<std::mutex> lock(mutex);
        acknowledged.insert(stamp);
        timings.emplace(stamp, Timing{now, m.detection_ms(), m.total_ms()});
      });

  ros2::RosBridgeOptions bo;
  bo.outbound = false;
  bo.max_pending_frames = 1000;
  bo.wait_for_components =
      components.names();  // as the player: no frame before every component is there
  auto bridge = std::make_unique<ros2::RosBridge>(MakeParticipant(domain, "test_bridge"), bo);

  CyclonePeer peer(domain);
  peer.Advertise("rt/camera/camera/color/image_raw",
                 "rt/camera/camera/aligned_depth_to_color/image_raw",
                 "rt/camera/camera/color/camera_info");
  ASSERT_TRUE(peer.WaitForCameraReaders(std::chrono::seconds(15)));
  const testing::PeerCamera camera = testing::PeerCameraOf(options.camera);

  // A driver that publishes the next frame once slam answered the previous one (lockstep, as
  // the player's back-pressure; a lost best-effort image is published again).
  std::vector<double> round_trip_ms, detection_ms, slam_ms;
  const testing::LockstepResult lockstep = testing::PublishInLockstep(
      peer, dataset, indices, camera,
      [&](int64_t stamp) {
        std::lock_guard<std::mutex> lock(mutex);
        return acknowledged.count(stamp) > 0;
      },
      [&](int64_t stamp, std::chrono::steady_clock::time_point published) {
        std::lock_guard<std::mutex> lock(mutex);
        const Timing& t = timings.at(stamp);
        round_trip_ms.push_back(
            std::chrono::duration<double, std::milli>(t.answered - published).count());
        detection_ms.push_back(t.detection_ms);
        slam_ms.push_back(t.total_ms);
      });
  ASSERT_TRUE(lockstep.all_answered) << "slam never answered frame " << lockstep.unanswered_stamp;
  const size_t republished = lockstep.republished;
  bridge->EndInput();
  components.Finish();
  const ros2::RosBridgeStats s = bridge->stats();
  bridge.reset();
  EXPECT_EQ(components.code("slam"), 0);
  EXPECT_EQ(components.code("recorder"), 0);
  EXPECT_EQ(s.frames_forwarded, indices.size());
  EXPECT_EQ(s.bad_samples, 0u);
  EXPECT_TRUE(s.end_of_stream_sent);
  EXPECT_LE(republished, indices.size() / 10) << "best-effort images lost too often";

  const auto estimate = ReadTumTrajectory(po.output_dir + "/trajectory.txt");
  EXPECT_GE(estimate.size(), indices.size() * 9 / 10);
  const double bridge_ate = ComputeAte(groundtruth, estimate).error.rmse;
  RecordProperty("direct_ate_m", std::to_string(direct_ate));
  RecordProperty("bridge_ate_m", std::to_string(bridge_ate));
  std::cout << "ATE direct " << direct_ate << " m, through the ROS 2 bridge " << bridge_ate
            << " m (" << indices.size() << " frames, " << republished << " republished)\n";
  auto percentile = [](std::vector<double> v, double q) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    return v[std::min(v.size() - 1, static_cast<size_t>(q * v.size()))];
  };
  std::cout << "publish -> CameraPose round trip: median " << percentile(round_trip_ms, 0.5)
            << " ms, p90 " << percentile(round_trip_ms, 0.9) << " ms; detector inference median "
            << percentile(detection_ms, 0.5) << " ms, slam total median "
            << percentile(slam_ms, 0.5) << " ms\n";
  // The acceptance: through the bridge no more than 10 % worse than the direct run. Measured with
  // the shipped defaults: direct 0.0133 m, through the bridge 0.0105 m (0.79x). The two inputs
  // differ (the peer's 16UC1 millimetre depth and its camera info), so the two runs are not the
  // same trajectory; the bridge path is held to the direct run's figure, not to its poses.
  EXPECT_LE(bridge_ate, 1.10 * direct_ate);
}

// A 50 MB image from a ROS 2 peer cannot arrive whole (its fragments overflow the receive
// buffers); the bridge reports it, from the middleware's sample-lost status of its colour reader,
// in its statistics by topic instead of losing it without a word. The images sent after it are
// counted once they arrive, lost or not (the peer keeps sending until the loss is reported).
TEST(Interop, OversizedImageFromThePeerIsCountedAsLost) {
  const int domain = 176;
  ros2::RosBridgeOptions bo;
  bo.outbound = false;
  bo.wait_for_components = {};  // no pipeline: only the ROS side is under test
  ros2::RosBridge bridge(MakeParticipant(domain, "test_bridge"), bo);
  CyclonePeer peer(domain);
  peer.Advertise("rt" + bo.color_topic, "rt" + bo.depth_topic, "rt" + bo.camera_info_topic);
  ASSERT_TRUE(peer.WaitForCameraReaders(std::chrono::seconds(15)));
  testing::PeerCamera camera;
  camera.fx = camera.fy = 525;
  camera.cx = 319.5;
  camera.cy = 239.5;
  const cv::Mat color(480, 640, CV_8UC3, cv::Scalar(40, 80, 120));
  const cv::Mat depth(480, 640, CV_16UC1, cv::Scalar(1500));
  cv::Mat huge(4267, 4096, CV_8UC3);  // 52.4 MB
  cv::randu(huge, 0, 255);
  int64_t stamp = 1'700'000'000'000'000'000;
  auto publish = [&](const cv::Mat& bgr) {
    stamp += 33'000'000;
    peer.PublishFrame(stamp, bgr, depth, camera, "camera_color_optical_frame");
  };
  // Good frames first: the reader is receiving.
  for (int i = 0; i < 3; ++i) {
    publish(color);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_TRUE(
      WaitUntil([&] { return bridge.stats().color_received == 3; }, std::chrono::seconds(10)))
      << bridge.stats().color_received << " of 3 colour images before the large one";
  publish(huge);
  size_t sent = 4;
  const auto lost_color = [&] {
    const ros2::RosBridgeStats s = bridge.stats();
    const auto it = s.lost_by_topic.find(bo.color_topic);
    return it == s.lost_by_topic.end() ? size_t{0} : it->second;
  };
  // A loss is known when a later sample of the same writer arrives, and once an image arrives,
  // every image sent before it was either received or counted lost: good images follow until
  // one arrives after the large one was counted.
  bool settled = false;
  for (int attempt = 0; attempt < 50 && !settled; ++attempt) {
    const size_t received_before = bridge.stats().color_received;
    publish(color);
    ++sent;
    const bool arrived = WaitUntil([&] { return bridge.stats().color_received > received_before; },
                                   std::chrono::seconds(2));
    settled = arrived && lost_color() >= 1;
  }
  ASSERT_TRUE(settled) << "no loss counted on the colour topic after " << sent << " images";
  // Nothing the peer sent vanished uncounted: every colour image was received or counted lost.
  EXPECT_TRUE(WaitUntil([&] { return bridge.stats().color_received + lost_color() == sent; },
                        std::chrono::seconds(2)));
  const ros2::RosBridgeStats s = bridge.stats();
  std::cout << "after the 52 MB image: " << sent - 4 << " good images sent, colour received "
            << s.color_received << " (3 before it), lost on the colour topic " << lost_color()
            << ", on all topics " << s.samples_lost << "\n";
  EXPECT_EQ(s.color_received + lost_color(), sent);
  EXPECT_GE(s.samples_lost, lost_color());
}

}  // namespace
}  // namespace dygslam
