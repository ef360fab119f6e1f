#include "components/detector_core.h"

#include <chrono>
#include <vector>

namespace dygslam {

DetectorCore::DetectorCore(const DetectorOptions& options)
    : detector_(YoloDetector::Create(options)) {}

msg::Detections DetectorCore::Process(const RgbdFrameData& frame) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<Detection> detections = detector_->Detect(frame.rgb);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return DetectionsToMsg(detections, frame.stamp, frame.seq, ms);
}

}  // namespace dygslam
