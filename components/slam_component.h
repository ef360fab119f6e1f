// Slam component: RgbdFrame (+ Detections) -> CameraPose per frame, Keyframe on each new keyframe
// / pose correction, the final Trajectory (frames and keyframes) at the end.
//
// Core: SlamCore (components/slam_core.h, no DDS) wraps dygslam::System. Shell: RunSlam pairs
// frames with detections by stamp (FramePairer: --deterministic waits for every frame's detections;
// normal mode waits at most detection_wait and counts misses; a frame without its own detections is
// filtered with the newest earlier boxes carried forward (CameraPose.detections_carried_forward),
// geometry-only when there are none recent; reported in the stats and in
// CameraPose.detections_missing). Ends when END_OF_STREAM's frame count has been processed (or 3 s
// after END_OF_STREAM without new frames, or on stop; or when the frame source announces FAILED):
// System::Shutdown(), final trajectories published, COMPONENT_DONE. Frames and detections are taken
// only from writers that this run's components announced (STARTED; components/protocol.h); others
// are ignored, counted and reported. With `Detector.every_n_frames` = n > 1 the detector component
// runs on the frames whose seq is a multiple of n; slam does not wait for the others and the
// System carries the boxes to them (SystemOptions::detection_every_n_frames,
// System::FeedRgbdFrameCarryingBoxes).
#pragma once

#include <cstddef>
#include <memory>

#include "components/component_common.h"
#include "components/frame_pairing.h"
#include "components/slam_core.h"

namespace dygslam {

namespace dds {
class Participant;
}

struct SlamStats {
  PairingStats pairing;
  // The frame source left without announcing the end of its stream (killed): the frames that
  // came are processed and the outputs written, but the stream was cut short.
  bool input_cut_short = false;
  size_t frames_processed = 0;
  size_t frames_tracked = 0;
  size_t keyframes_published = 0;  // Keyframe messages: new + pose updates + removals
  size_t keyframe_pose_updates = 0;
  size_t keyframes_removed = 0;
  // Keyframe messages no reader got (refused by the writer until the end: a reader that never
  // acknowledged; or more than the bounded backlog): the map lacks them, the run is incomplete.
  size_t keyframe_messages_undelivered = 0;
  size_t bad_samples = 0;
  size_t frames_carrying_boxes = 0;  // detector skipped by the cadence: the System's carried boxes
  // Frames filtered without any person boxes although the run asked for them: due their own boxes
  // and none came or could be carried, or skipped by the cadence after such a frame (nothing to
  // carry).
  size_t frames_without_boxes = 0;
  bool detector_lost = false;
  bool detector_failed = false;  // it announced FAILED (a model it could not load)
  // Where slam waited between its first and its last frame (seconds): no frame had arrived
  // (upstream: player / transport), or the oldest frame waited for its detections (detector).
  double wait_for_frames_s = 0;
  double wait_for_detections_s = 0;
  double busy_s = 0;  // processing frames (System + publishing)
  // Samples of writers no component of this run announced (components/protocol.h), ignored.
  size_t foreign_frames = 0;
  size_t foreign_detections = 0;
  // END_OF_STREAM / DONE statuses of participants that announced no component of the run
  // (RunWriters::NumForeignStatuses): not acted on.
  size_t foreign_statuses = 0;
  // --save-map FILE that could not be written (SlamCore::save_map_error); "" when saved or none.
  std::string save_map_error;
};

SlamStats RunSlam(std::shared_ptr<dds::Participant> participant,
                  const SlamComponentOptions& options, const StopFlagPtr& stop);

}  // namespace dygslam
