#include "fuzz/dds_decoders.h"

#include <cmath>
#include <stdexcept>

namespace dygslam::fuzz {
namespace {

// Content checks: what a decoder accepted must be consistent (the components rely on it).
void CheckFrame(const RgbdFrameData& f) {
  if (f.rgb.empty() || f.depth.empty()) return;
  if (f.rgb.cols != f.camera.width || f.rgb.rows != f.camera.height ||
      f.depth.size() != f.rgb.size()) {
    throw std::logic_error("RgbdFrameFromMsg accepted images that disagree with the camera");
  }
  if (f.rgb.type() != CV_8UC3 || (f.depth.type() != CV_16UC1 && f.depth.type() != CV_32FC1)) {
    throw std::logic_error("RgbdFrameFromMsg accepted an unexpected image type");
  }
  if (!(f.depth_scale > 0) || !std::isfinite(f.depth_scale)) {
    throw std::logic_error("RgbdFrameFromMsg accepted a bad depth scale");
  }
}
void CheckPose(const Rigid3d& p, const char* what) {
  if (!p.AllFinite() || std::abs(p.rotation.norm() - 1.0) > 1e-6) {
    throw std::logic_error(std::string(what) + " accepted a non-finite or non-unit pose");
  }
}

template <class PubSubType, class Convert>
DecodeResult Decode(const uint8_t* bytes, size_t size, Convert convert) {
  typename PubSubType::type message;
  DecodeResult r = Deserialize<PubSubType>(bytes, size, &message);
  if (r.status != DecodeStatus::kOk) return r;
  try {
    convert(message);
  } catch (const InputError& e) {
    return {DecodeStatus::kRejectedContent, e.what()};
  }
  return r;
}

}  // namespace

const char* ToString(SampleKind kind) {
  switch (kind) {
    case SampleKind::kRgbdFrame: return "RgbdFrame";
    case SampleKind::kDetections: return "Detections";
    case SampleKind::kCameraPose: return "CameraPose";
    case SampleKind::kKeyframe: return "Keyframe";
    case SampleKind::kGroundTruth: return "GroundTruthPose";
    case SampleKind::kTrajectory: return "Trajectory";
    case SampleKind::kStreamStatus: return "StreamStatus";
    case SampleKind::kMapUpdate: return "MapUpdate";
    case SampleKind::kCount: break;
  }
  return "?";
}

DecodeResult DecodeSample(SampleKind kind, const uint8_t* bytes, size_t size) {
  switch (kind) {
    case SampleKind::kRgbdFrame:
      return Decode<msg::RgbdFramePubSubType>(bytes, size, [](const msg::RgbdFrame& m) {
        CheckFrame(RgbdFrameFromMsg(m));
      });
    case SampleKind::kDetections:
      return Decode<msg::DetectionsPubSubType>(bytes, size, [](const msg::Detections& m) {
        for (const Detection& d : DetectionsFromMsg(m)) {
          if (!std::isfinite(d.box.x) || !std::isfinite(d.box.width) || !std::isfinite(d.score)) {
            throw std::logic_error("DetectionsFromMsg accepted a non-finite detection");
          }
        }
        TimeFromMsg(m.header().stamp(), "Detections.header.stamp");
      });
    case SampleKind::kCameraPose:
      // As the recorder (RecorderCore::AddPose) decodes it.
      return Decode<msg::CameraPosePubSubType>(bytes, size, [](const msg::CameraPose& m) {
        TimeFromMsg(m.header().stamp(), "CameraPose.header.stamp");
        if (m.has_pose()) CheckPose(PoseFromMsg(m.world_from_cam(), "CameraPose.world_from_cam"), "PoseFromMsg");
      });
    case SampleKind::kKeyframe:
      return Decode<msg::KeyframePubSubType>(bytes, size, [](const msg::Keyframe& m) {
        PinholeCamera camera;
        const KeyframeData k = KeyframeFromMsg(m, &camera);
        if (!k.removed && !k.pose_update_only) CheckPose(k.world_from_cam, "KeyframeFromMsg");
        if (k.keypoints.size() != k.keypoint_dynamic.size() && !k.keypoint_dynamic.empty()) {
          throw std::logic_error("KeyframeFromMsg accepted mismatched keypoint flags");
        }
      });
    case SampleKind::kGroundTruth:
      return Decode<msg::GroundTruthPosePubSubType>(bytes, size, [](const msg::GroundTruthPose& m) {
        CheckPose(GroundTruthFromMsg(m).world_from_cam, "GroundTruthFromMsg");
      });
    case SampleKind::kTrajectory:
      return Decode<msg::TrajectoryPubSubType>(bytes, size, [](const msg::Trajectory& m) {
        for (const StampedPose& p : TrajectoryFromMsg(m)) CheckPose(p.world_from_cam, "TrajectoryFromMsg");
      });
    case SampleKind::kStreamStatus:
      return Decode<msg::StreamStatusPubSubType>(bytes, size, [](const msg::StreamStatus& m) {
        TimeFromMsg(m.header().stamp(), "StreamStatus.header.stamp");
      });
    case SampleKind::kMapUpdate:
      return Decode<msg::MapUpdatePubSubType>(bytes, size, [](const msg::MapUpdate&) {});
    case SampleKind::kCount: break;
  }
  throw std::logic_error("DecodeSample: bad kind");
}

}  // namespace dygslam::fuzz
