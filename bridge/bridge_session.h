// `dygslam bridge` below the command line: the ROS 2 bridge on the pipeline's DDS domain, with the
// SLAM components (detector, slam, mapper, recorder) on threads of the same process when asked
// (--run-slam). Runs until `stop` or the end of the stream; its counts go to stderr.
//
//   BridgeSessionOptions o;  // filled from the command line
//   const int exit_code = RunBridgeSession(o, stop);
#pragma once

#include <optional>
#include <string>

#include "bridge/ros2_bridge.h"
#include "components/pipeline.h"

namespace dygslam::ros2 {

struct BridgeSessionOptions {
  RosBridgeOptions bridge;
  int domain_id = 0;      // the pipeline's domain, also the ROS 2 side's (ROS_DOMAIN_ID)
  std::string partition;  // of the pipeline's topics ("" none); the ROS 2 topics stay outside
  // The components run here (--run-slam), on `domain_id` / `partition`; none when empty.
  std::optional<PipelineOptions> components;
  // The bridge waits for the components run here unless the user named the ones to wait for.
  bool wait_for_given = false;
  // The ROS 2 side: on the pipeline's participant (shared memory + 127.0.0.1 only), or on a
  // participant of its own with ROS 2's network profile (with or without shared memory).
  bool ros_on_pipeline_participant = false;
  bool ros_shared_memory = true;
};

// Runs the bridge (and the components); returns 0, or 1 when a component failed. Rethrows what
// stopped the bridge after the components have ended.
int RunBridgeSession(BridgeSessionOptions options, const StopFlagPtr& stop);

}  // namespace dygslam::ros2
