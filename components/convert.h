// Conversions between the library types (cv::Mat, Detection, KeyframeData, Rigid3d, Timestamp,
// PinholeCamera) and the DDS message types of idl/ (module dygslam::msg).
//
// Every *FromMsg function validates what comes off the wire and throws dygslam::InputError naming
// the offending field (e.g. "RgbdFrame.depth.data: 1000 bytes, expected step 1280 x height 480 =
// 614400"): unknown encodings, absurd dimensions (0 or > 16384), step != width x bytes per pixel,
// data length != step x height, image sizes that disagree with the camera, non-finite or
// non-unit poses, nanosec >= 1e9, non-finite boxes / scores, keypoint / flag count mismatch.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/base/camera.h"
#include "core/base/rgbd_frame.h"
#include "core/base/rigid3.h"
#include "core/base/timestamp.h"
#include "core/base/types.h"
#include "dygslam_msg/CameraPose.h"
#include "dygslam_msg/Common.h"
#include "dygslam_msg/Detections.h"
#include "dygslam_msg/GroundTruth.h"
#include "dygslam_msg/Keyframe.h"
#include "dygslam_msg/RgbdFrame.h"
#include "dygslam_msg/StreamStatus.h"
#include "dygslam_msg/Trajectory.h"

namespace dygslam {

// Largest accepted image side (pixels).
inline constexpr uint32_t kMaxImageSide = 16384;

// An RGB-D frame as the components handle it (library side of msg::RgbdFrame): the core's frame
// (stamp, rgb CV_8UC3 BGR, depth CV_16UC1 raw with depth_scale or CV_32FC1 metres) with the
// message header and camera. The frame's mask and detections are not part of the message.
struct RgbdFrameData : RgbdFrame {
  uint64_t seq = 0;
  std::string frame_id = "camera";
  PinholeCamera camera;
};

msg::Time TimeToMsg(Timestamp stamp);
Timestamp TimeFromMsg(const msg::Time& time, const std::string& field);

msg::Pose PoseToMsg(const Rigid3d& pose);
// Rejects non-finite values and quaternions whose norm is off by more than 1e-3 (normalises the
// rest).
Rigid3d PoseFromMsg(const msg::Pose& pose, const std::string& field);

// Encoding from the Mat type: CV_8UC3 "bgr8", CV_8UC1 "mono8", CV_16UC1 "16UC1", CV_32FC1
// "32FC1". An empty Mat gives an empty image. Throws std::invalid_argument for other types.
msg::Image ImageToMsg(const cv::Mat& image);
// Deep copy. "rgb8" is converted to BGR (CV_8UC3). An image with width = height = 0 and no data
// gives an empty Mat.
cv::Mat ImageFromMsg(const msg::Image& image, const std::string& field);
// Bytes per pixel of an encoding, 0 if unknown.
int BytesPerPixel(const std::string& encoding);

msg::CameraIntrinsics CameraToMsg(const PinholeCamera& camera, double depth_scale);
PinholeCamera CameraFromMsg(const msg::CameraIntrinsics& camera, const std::string& field,
                            double* depth_scale = nullptr);

msg::RgbdFrame RgbdFrameToMsg(const RgbdFrameData& frame);
// Also checks colour and depth sizes against camera.width/height and the depth encoding
// ("16UC1" / "32FC1").
RgbdFrameData RgbdFrameFromMsg(const msg::RgbdFrame& frame);

msg::Detection2D DetectionToMsg(const Detection& detection);
Detection DetectionFromMsg(const msg::Detection2D& detection, const std::string& field);
msg::Detections DetectionsToMsg(const std::vector<Detection>& detections, Timestamp stamp,
                                uint64_t seq, double inference_ms = 0);
std::vector<Detection> DetectionsFromMsg(const msg::Detections& detections);

msg::Keyframe KeyframeToMsg(const KeyframeData& keyframe, const PinholeCamera& camera);
KeyframeData KeyframeFromMsg(const msg::Keyframe& keyframe, PinholeCamera* camera = nullptr);

msg::GroundTruthPose GroundTruthToMsg(const StampedPose& pose, uint64_t seq);
StampedPose GroundTruthFromMsg(const msg::GroundTruthPose& pose);

msg::Trajectory TrajectoryToMsg(const std::vector<StampedPose>& poses, bool keyframes_only);
std::vector<StampedPose> TrajectoryFromMsg(const msg::Trajectory& trajectory);

// StreamStatus.num_frames (uint64 on the wire) as the components count frames: saturated at
// INT64_MAX, never negative (a plain cast turns an absurd value into -1, "no end announced", and
// the component would wait forever). A count that large is never reached; the components then
// finish on their idle timeout after END_OF_STREAM.
int64_t StreamFrameCountFromMsg(const msg::StreamStatus& status);

}  // namespace dygslam
