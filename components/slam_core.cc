#include "components/slam_core.h"

#include <cmath>

#include "core/base/error.h"
#include "core/base/log.h"

namespace dygslam {

void SlamComponentOptions::Check() const {
  system.Check();
  DYGSLAM_CHECK_OPTION(detection_wait.count() >= 0, "slam.detection_wait_ms");
  DYGSLAM_CHECK_OPTION(detector_lost_after_misses >= 1, "slam.detector_lost_after_misses");
  DYGSLAM_CHECK_OPTION(carry_forward_max_frames >= 0, "slam.carry_forward_max_frames");
}

bool SlamComponentOptions::NeedsDetections() const {
  return external_detections && system.NeedsDetections();
}

SlamCore::SlamCore(const SlamComponentOptions& options)
    : options_(options), system_(std::make_unique<System>(options.system)) {
  options_.Check();
  system_->SetKeyframeCallback([this](const KeyframeData& k) {
    std::lock_guard<std::mutex> lock(keyframes_mutex_);
    keyframes_.push_back(k);
  });
}

std::vector<KeyframeData> SlamCore::TakeKeyframes() {
  std::lock_guard<std::mutex> lock(keyframes_mutex_);
  std::vector<KeyframeData> out;
  out.swap(keyframes_);
  return out;
}

SlamOutput SlamCore::Process(const RgbdFrameData& frame, const std::vector<Detection>* detections,
                             bool detector_skipped) {
  SlamOutput out;
  RgbdFrame input = frame;  // the core's frame (images shared); raw depth goes in with its scale
  if (detector_skipped && options_.NeedsDetections()) {
    out.result = system_->FeedRgbdFrameCarryingBoxes(input);
    out.keyframes = TakeKeyframes();
    return out;
  }
  if (detections != nullptr) {
    input.detections = *detections;
  } else if (options_.NeedsDetections()) {
    input.detections.emplace();  // geometry-only frame
  }
  out.result = system_->FeedRgbdFrame(input);
  out.keyframes = TakeKeyframes();
  return out;
}

std::vector<KeyframeData> SlamCore::Finish() {
  if (!finished_) {
    system_->Shutdown();
    finished_ = true;
    if (!options_.save_map.empty()) {
      try {
        LOG_INFO << "slam: map file saved " << options_.save_map << " ("
                 << DescribeMapFile(system_->SaveMap(options_.save_map)) << ")";
      } catch (const std::exception& e) {
        save_map_error_ = e.what();
      }
    }
  }
  return TakeKeyframes();
}

msg::CameraPose CameraPoseToMsg(const FrameResult& r, uint64_t seq, bool detections_missing,
                                bool detections_carried_forward) {
  msg::CameraPose m;
  m.header().stamp(TimeToMsg(r.stamp));
  m.header().frame_id("world");
  m.header().seq(seq);
  m.tracking_state(static_cast<uint8_t>(r.state));
  m.has_pose(r.world_from_cam.has_value());
  if (r.world_from_cam) m.world_from_cam(PoseToMsg(*r.world_from_cam));
  m.is_keyframe(r.is_keyframe);
  m.num_features(r.num_features);
  m.num_dynamic(r.num_dynamic);
  m.num_tracked(r.num_tracked);
  m.detections_used(r.detections_used);
  m.detections_missing(detections_missing);
  m.detections_carried_forward(detections_carried_forward);
  m.orb_extraction_ms(r.times.orb_extraction_ms);
  m.detection_ms(r.times.detection_ms);
  m.detection_wait_ms(r.times.detection_wait_ms);
  m.matching_ms(r.times.matching_ms);
  m.probability_ms(r.times.probability_ms);
  m.tracking_ms(r.times.tracking_ms);
  m.local_mapping_ms(r.times.local_mapping_ms);
  m.total_ms(r.times.total_ms);
  return m;
}

}  // namespace dygslam
