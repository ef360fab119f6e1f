// SlamCore: the slam component's work without DDS. Wraps dygslam::System: one RGB-D frame (and
// the detector component's boxes, if any) in, the frame's result and the keyframes the System
// emitted meanwhile out; Finish() shuts the System down (final keyframe corrections, the SLAM map
// file if asked). The shell (slam_component.h) pairs frames with detections and publishes.
#pragma once

#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "components/convert.h"
#include "core/system/system.h"
#include "dygslam_msg/CameraPose.h"

namespace dygslam {

struct SlamComponentOptions {
  SystemOptions system;
  // Take detections from the detector component (true) or let System run its own detector
  // (false; then System needs the model paths).
  bool external_detections = true;
  std::chrono::milliseconds detection_wait{1000};
  int detector_lost_after_misses = 5;
  // A frame whose detections are late gets the newest earlier boxes for at most this many frames
  // in a row (FramePairer); 0: such frames run geometry-only.
  int carry_forward_max_frames = 30;
  // SLAM map file written when the component finishes (end of stream or stop); "": none. The map
  // to start from and localization mode are system.load_map / system.localization.
  std::string save_map;
  void Check() const;
  bool NeedsDetections() const;
};

struct SlamOutput {
  FrameResult result;
  std::vector<KeyframeData> keyframes;  // emitted while processing this frame (or before)
};

class SlamCore {
 public:
  explicit SlamCore(const SlamComponentOptions& options);
  // detections == nullptr: no external detections (the System runs its own if it needs them and
  // external_detections is false; otherwise the frame goes on without boxes). detector_skipped:
  // the detector component does not run on this frame (cadence): the System carries the boxes.
  SlamOutput Process(const RgbdFrameData& frame, const std::vector<Detection>* detections,
                     bool detector_skipped = false);
  // Shutdown + final keyframe corrections.
  std::vector<KeyframeData> Finish();
  std::vector<StampedPose> Trajectory() const { return system_->Trajectory(); }
  std::vector<StampedPose> KeyframeTrajectory() const { return system_->KeyframeTrajectory(); }
  const PinholeCamera& camera() const { return options_.system.camera; }
  std::optional<MapFileInfo> LoadedMapInfo() const { return system_->LoadedMapInfo(); }

 private:
  std::vector<KeyframeData> TakeKeyframes();
  SlamComponentOptions options_;
  std::unique_ptr<System> system_;
  std::mutex keyframes_mutex_;
  std::vector<KeyframeData> keyframes_;
  bool finished_ = false;
};

// One frame's result as slam publishes it (dygslam/camera_pose).
msg::CameraPose CameraPoseToMsg(const FrameResult& result, uint64_t seq, bool detections_missing,
                                bool detections_carried_forward = false);

}  // namespace dygslam
