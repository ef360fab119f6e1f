#include "bridge/bridge_session.h"

#include <iostream>
#include <mutex>
#include <thread>
#include <vector>

#include "components/dds/participant.h"
#include "core/base/log.h"

namespace dygslam::ros2 {
namespace {

// The bridge's counts, on stderr.
void PrintBridgeStats(const RosBridgeStats& s) {
  std::cerr << "ros2 bridge: " << s.frames_forwarded << " frames forwarded (colour "
            << s.color_received << ", depth " << s.depth_received << ", unpaired "
            << s.dropped_unsynchronized << ", no camera info " << s.dropped_no_camera_info
            << ", dropped waiting " << s.dropped_pending << ", bad " << s.bad_samples
            << ", lost before the bridge " << s.samples_lost << "); " << s.poses << " poses, "
            << s.paths << " paths, " << s.detections << " detection arrays, " << s.maps
            << " maps published\n";
  for (const auto& [kind, count] : s.rejected) {
    std::cerr << "ros2 bridge: rejected " << count << " sample(s): " << kind << "\n";
  }
  for (const auto& [topic, count] : s.lost_by_topic) {
    if (count > 0)
      std::cerr << "ros2 bridge: " << count << " sample(s) lost before the bridge on " << topic
                << " (in transport or rejected by the reader)\n";
  }
}

}  // namespace

int RunBridgeSession(BridgeSessionOptions options, const StopFlagPtr& stop) {
  RosBridgeOptions& o = options.bridge;
  std::vector<std::thread> threads;
  std::mutex mutex;
  int result = 0;
  if (options.components) {
    const PipelineOptions& pipeline = *options.components;
    std::vector<std::string> names = {"recorder", "slam"};
    if (pipeline.run_mapper) names.push_back("mapper");
    if (pipeline.NeedsDetectorComponent()) names.push_back("detector");
    if (!options.wait_for_given) o.wait_for_components = names;
    for (const std::string& name : names) {
      threads.emplace_back([&, name] {
        try {
          const int code = RunComponent(name, pipeline, stop);
          std::lock_guard<std::mutex> lock(mutex);
          if (code != 0) result = 1;
        } catch (const std::exception& e) {
          LOG_ERROR << name << ": " << e.what();
          std::lock_guard<std::mutex> lock(mutex);
          result = 1;
          stop->Request();
        }
      });
    }
  }
  dds::ParticipantOptions po;
  po.domain_id = options.domain_id;
  po.name = "dygslam_ros2_bridge_pipeline";
  po.partition = options.partition;
  LOG_INFO << "ros2 bridge on domain " << options.domain_id
           << (options.partition.empty() ? ""
                                         : " (pipeline partition '" + options.partition + "')")
           << ": in " << o.color_topic << " + " << o.depth_topic << " + " << o.camera_info_topic
           << "; out " << o.pose_topic << ", " << o.path_topic << ", " << o.odom_topic << ", "
           << o.tf_topic << ", " << o.detections_topic << ", " << o.octomap_topic;
  RosBridgeStats s;
  try {
    auto pipeline_participant = dds::Participant::Create(po);
    std::shared_ptr<dds::Participant> ros_participant = pipeline_participant;
    if (!options.ros_on_pipeline_participant) {
      ros_participant = dds::Participant::Create(
          RosParticipantOptions(options.domain_id, options.ros_shared_memory));
    }
    s = RunBridge(pipeline_participant, ros_participant, o, stop);
  } catch (...) {
    stop->Request();
    for (std::thread& t : threads) t.join();
    throw;
  }
  stop->Request();
  for (std::thread& t : threads) t.join();
  PrintBridgeStats(s);
  return result;
}

}  // namespace dygslam::ros2
