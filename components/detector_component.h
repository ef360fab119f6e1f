// Detector component: RgbdFrame -> Detections (same stamp + seq as the frame).
// Core: DetectorCore (components/detector_core.h, no DDS). Shell: RunDetector.
// Every received frame is processed in arrival order (slam in --deterministic mode waits for
// the detections of every frame; the player's back-pressure bounds the queue). Stops after the
// END_OF_STREAM frame count has been processed, or on stop.
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
  size_t bad_samples = 0;
  double mean_inference_ms = 0;
};

DetectorStats RunDetector(std::shared_ptr<dds::Participant> participant,
                          const DetectorOptions& options, const StopFlagPtr& stop);

}  // namespace dygslam
