// Detector component: RgbdFrame -> Detections (same stamp + seq as the frame).
// Core: DetectorCore (components/detector_core.h, no DDS). Shell: RunDetector.
// Every received frame is processed in arrival order (slam in --deterministic mode waits for
// the detections of every frame; the player's back-pressure bounds the queue); with a cadence
// (`Detector.every_n_frames` = n > 1) only the frames whose seq is a multiple of n: slam knows
// the others get none and carries the boxes to them. Stops after the END_OF_STREAM frame count
// has been received, or on stop.
#pragma once

#include <cstddef>
#include <memory>

#include "components/component_common.h"
#include "components/detector_core.h"

namespace dygslam {

namespace dds {
class Participant;
}

struct DetectorStats {
  size_t frames_processed = 0;
  size_t frames_skipped = 0;  // not detected: the cadence (every_n_frames)
  size_t bad_samples = 0;
  double mean_inference_ms = 0;
};

// every_n_frames: detect the frames with seq % every_n_frames == 0 (1..1000; the settings'
// Detector.every_n_frames, the same value slam uses).
DetectorStats RunDetector(std::shared_ptr<dds::Participant> participant,
                          const DetectorOptions& options, const StopFlagPtr& stop,
                          int every_n_frames = 1);

}  // namespace dygslam
