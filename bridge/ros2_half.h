// One half of the ROS 2 bridge (RosInbound: ROS camera -> pipeline; RosOutbound: pipeline ->
// ROS), as RosBridge (ros2_bridge.cc) drives both: writers, then threads, then readers (their
// callbacks need the rest); on stop, readers first (no callback after StopReaders returns), then
// the threads, then a bounded wait for reliable readers to receive the last samples.
#pragma once

#include <chrono>

#include "bridge/ros2_bridge.h"

namespace dygslam::ros2 {

class RosHalf {
 public:
  RosHalf() = default;
  virtual ~RosHalf() = default;
  RosHalf(const RosHalf&) = delete;
  RosHalf& operator=(const RosHalf&) = delete;

  virtual void CreateWriters() = 0;
  virtual void StartThread() = 0;
  virtual void CreateReaders() = 0;
  virtual void StopReaders() = 0;
  virtual void StopThread() = 0;
  virtual void WaitForAcknowledgments(std::chrono::milliseconds timeout) = 0;
  // This half's fields of the bridge statistics (the other half's stay 0).
  virtual RosBridgeStats stats() const = 0;
};

}  // namespace dygslam::ros2
