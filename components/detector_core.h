// DetectorCore: the detector component's work without DDS. One frame's colour image -> the
// person boxes of the YOLO detector (core/dynamic/yolo_detector.h) as the Detections message of
// that frame (same stamp and seq), with the inference time. The shell (detector_component.h)
// reads frames and writes the result.
#pragma once

#include <memory>

#include "components/convert.h"
#include "core/dynamic/yolo_detector.h"
#include "dygslam_msg/Detections.h"

namespace dygslam {

class DetectorCore {
 public:
  // Throws as YoloDetector::Create does for a missing or unreadable model.
  explicit DetectorCore(const DetectorOptions& options);
  // Detections of one frame (the frame's colour image), with the inference time.
  msg::Detections Process(const RgbdFrameData& frame);

 private:
  std::unique_ptr<YoloDetector> detector_;
};

}  // namespace dygslam
