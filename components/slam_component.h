// Slam component: RgbdFrame (+ Detections) -> CameraPose per frame, Keyframe on each new keyframe
// / pose correction, the final Trajectory (frames and keyframes) at the end.
//
// Core: SlamCore (no DDS) wraps dygslam::System. Shell: RunSlam pairs frames with detections by
// stamp (FramePairer: --deterministic waits for every frame's detections; normal mode waits at
// most detection_wait and counts misses; a frame without its own detections is filtered with the
// newest earlier boxes carried forward (CameraPose.detections_carried_forward), geometry-only
// when there are none recent; reported in the stats and in CameraPose.detections_missing). With
// `Detector.every_n_frames` = n > 1 the detector component runs on the frames whose seq is a
// multiple of n; slam does not wait for the others and the System carries the boxes to them
// (SystemOptions::detection_every_n_frames, System::FeedRgbdFrameCarryingBoxes). Ends
// when END_OF_STREAM's frame count has been processed (or 3 s after END_OF_STREAM without new
// frames, or on stop; or when the frame source announces FAILED): System::Shutdown(), final
// trajectories published, COMPONENT_DONE. Frames and detections are taken only from writers that
// this run's components announced (STARTED; components/protocol.h); others are ignored, counted
// and reported.
#pragma once

#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "components/component_common.h"
#include "components/convert.h"
#include "components/frame_pairing.h"
#include "core/system/system.h"

namespace dygslam {

namespace dds {
class Participant;
}

struct SlamComponentOptions {
  SystemOptions system;
  // Take detections from the detector component (true) or let System run its own detector
  // (false; then System needs the model paths).
  bool external_detections = true;
  std::chrono::milliseconds detection_wait{150};
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

msg::CameraPose CameraPoseToMsg(const FrameResult& result, uint64_t seq, bool detections_missing,
                                bool detections_carried_forward = false);

struct SlamStats {
  PairingStats pairing;
  size_t frames_processed = 0;
  size_t frames_tracked = 0;
  size_t keyframes_published = 0;  // Keyframe messages: new + pose updates + removals
  size_t keyframe_pose_updates = 0;
  size_t keyframes_removed = 0;
  size_t bad_samples = 0;
  size_t frames_carrying_boxes = 0;  // detector skipped by the cadence: the System's carried boxes
  bool detector_lost = false;
  // Where slam waited between its first and its last frame (seconds): no frame had arrived
  // (upstream: player / transport), or the oldest frame waited for its detections (detector).
  double wait_for_frames_s = 0;
  double wait_for_detections_s = 0;
  double busy_s = 0;  // processing frames (System + publishing)
  // Samples of writers no component of this run announced (components/protocol.h), ignored.
  size_t foreign_frames = 0;
  size_t foreign_detections = 0;
};

SlamStats RunSlam(std::shared_ptr<dds::Participant> participant,
                  const SlamComponentOptions& options, const StopFlagPtr& stop);

}  // namespace dygslam
