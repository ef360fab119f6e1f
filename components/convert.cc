#include "components/convert.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

#include "core/base/error.h"
#include "core/base/image_encoding.h"

namespace dygslam {

namespace {

[[noreturn]] void Fail(const std::string& field, const std::string& what) {
  throw InputError(field + ": " + what);
}

bool Finite(float v) { return std::isfinite(v); }

}  // namespace

msg::Time TimeToMsg(Timestamp stamp) {
  const int64_t ns = stamp.nanoseconds();
  int64_t sec = ns / 1000000000;
  int64_t nsec = ns % 1000000000;
  if (nsec < 0) {
    nsec += 1000000000;
    sec -= 1;
  }
  msg::Time t;
  t.sec(static_cast<int32_t>(sec));
  t.nanosec(static_cast<uint32_t>(nsec));
  return t;
}

Timestamp TimeFromMsg(const msg::Time& time, const std::string& field) {
  if (time.nanosec() >= 1000000000u) {
    Fail(field + ".nanosec", std::to_string(time.nanosec()) + " is not below 1e9");
  }
  return Timestamp::FromNanoseconds(static_cast<int64_t>(time.sec()) * 1000000000 +
                                    static_cast<int64_t>(time.nanosec()));
}

msg::Pose PoseToMsg(const Rigid3d& pose) {
  msg::Pose p;
  p.position().x(pose.translation.x());
  p.position().y(pose.translation.y());
  p.position().z(pose.translation.z());
  const Eigen::Quaterniond q = pose.rotation.normalized();
  p.orientation().x(q.x());
  p.orientation().y(q.y());
  p.orientation().z(q.z());
  p.orientation().w(q.w());
  return p;
}

Rigid3d PoseFromMsg(const msg::Pose& pose, const std::string& field) {
  const Eigen::Vector3d t(pose.position().x(), pose.position().y(), pose.position().z());
  if (!t.allFinite()) Fail(field + ".position", "non-finite value");
  const Eigen::Quaterniond q(pose.orientation().w(), pose.orientation().x(), pose.orientation().y(),
                             pose.orientation().z());
  if (!q.coeffs().allFinite()) Fail(field + ".orientation", "non-finite value");
  const double norm = q.norm();
  if (std::abs(norm - 1.0) > 1e-3) {
    std::ostringstream s;
    s << "quaternion norm " << norm << " is not 1";
    Fail(field + ".orientation", s.str());
  }
  Rigid3d r;
  r.rotation = q.normalized();
  r.translation = t;
  return r;
}

int BytesPerPixel(const std::string& encoding) {
  if (encoding == "bgr8" || encoding == "rgb8") return 3;
  if (encoding == "mono8" || encoding == "8UC1") return 1;
  if (encoding == "16UC1" || encoding == "mono16") return 2;
  if (encoding == "32FC1") return 4;
  return 0;
}

msg::Image ImageToMsg(const cv::Mat& image) {
  msg::Image m;
  if (image.empty()) {
    m.width(0);
    m.height(0);
    m.step(0);
    return m;
  }
  m.encoding(ImageEncodingOf(image.type(), "ImageToMsg"));
  m.width(static_cast<uint32_t>(image.cols));
  m.height(static_cast<uint32_t>(image.rows));
  m.step(static_cast<uint32_t>(image.cols * image.elemSize()));
  m.data(PackedImageRows(image));
  return m;
}

cv::Mat ImageFromMsg(const msg::Image& image, const std::string& field) {
  if (image.width() == 0 && image.height() == 0 && image.data().empty()) return cv::Mat();
  const int bpp = BytesPerPixel(image.encoding());
  if (bpp == 0) Fail(field + ".encoding", "unknown encoding '" + image.encoding() + "'");
  if (image.width() == 0 || image.width() > kMaxImageSide) {
    Fail(field + ".width", std::to_string(image.width()) + " is not in [1, 16384]");
  }
  if (image.height() == 0 || image.height() > kMaxImageSide) {
    Fail(field + ".height", std::to_string(image.height()) + " is not in [1, 16384]");
  }
  const size_t row_bytes = static_cast<size_t>(image.width()) * bpp;
  if (image.step() != row_bytes) {
    Fail(field + ".step", std::to_string(image.step()) + ", expected width " +
                              std::to_string(image.width()) + " x " + std::to_string(bpp) +
                              " bytes (" + image.encoding() + ") = " + std::to_string(row_bytes));
  }
  const size_t expected = row_bytes * image.height();
  if (image.data().size() != expected) {
    Fail(field + ".data", std::to_string(image.data().size()) + " bytes, expected step " +
                              std::to_string(image.step()) + " x height " +
                              std::to_string(image.height()) + " = " + std::to_string(expected));
  }
  int type = CV_8UC1;
  if (bpp == 3) type = CV_8UC3;
  if (bpp == 2) type = CV_16UC1;
  if (bpp == 4) type = CV_32FC1;
  cv::Mat wrapped(static_cast<int>(image.height()), static_cast<int>(image.width()), type,
                  const_cast<uint8_t*>(image.data().data()));
  cv::Mat result;
  if (image.encoding() == "rgb8") {
    cv::cvtColor(wrapped, result, cv::COLOR_RGB2BGR);
  } else {
    result = wrapped.clone();
  }
  return result;
}

msg::CameraIntrinsics CameraToMsg(const PinholeCamera& camera, double depth_scale) {
  msg::CameraIntrinsics m;
  m.width(static_cast<uint32_t>(camera.width));
  m.height(static_cast<uint32_t>(camera.height));
  m.fx(camera.fx);
  m.fy(camera.fy);
  m.cx(camera.cx);
  m.cy(camera.cy);
  m.distortion({camera.k1, camera.k2, camera.p1, camera.p2, camera.k3});
  m.depth_scale(depth_scale);
  return m;
}

PinholeCamera CameraFromMsg(const msg::CameraIntrinsics& m, const std::string& field,
                            double* depth_scale) {
  if (m.width() == 0 || m.width() > kMaxImageSide) {
    Fail(field + ".width", std::to_string(m.width()) + " is not in [1, 16384]");
  }
  if (m.height() == 0 || m.height() > kMaxImageSide) {
    Fail(field + ".height", std::to_string(m.height()) + " is not in [1, 16384]");
  }
  PinholeCamera c;
  c.width = static_cast<int>(m.width());
  c.height = static_cast<int>(m.height());
  c.fx = m.fx();
  c.fy = m.fy();
  c.cx = m.cx();
  c.cy = m.cy();
  if (!(std::isfinite(c.fx) && c.fx > 0)) Fail(field + ".fx", "must be finite and > 0");
  if (!(std::isfinite(c.fy) && c.fy > 0)) Fail(field + ".fy", "must be finite and > 0");
  if (!std::isfinite(c.cx)) Fail(field + ".cx", "non-finite value");
  if (!std::isfinite(c.cy)) Fail(field + ".cy", "non-finite value");
  const std::vector<double>& d = m.distortion();
  if (d.size() != 0 && d.size() != 4 && d.size() != 5) {
    Fail(field + ".distortion",
         std::to_string(d.size()) + " coefficients, expected 0, 4 or 5 (k1 k2 p1 p2 [k3])");
  }
  for (double v : d) {
    if (!std::isfinite(v)) Fail(field + ".distortion", "non-finite coefficient");
  }
  if (d.size() >= 4) {
    c.k1 = d[0];
    c.k2 = d[1];
    c.p1 = d[2];
    c.p2 = d[3];
  }
  if (d.size() == 5) c.k3 = d[4];
  if (!(std::isfinite(m.depth_scale()) && m.depth_scale() > 0)) {
    Fail(field + ".depth_scale", "must be finite and > 0");
  }
  if (depth_scale != nullptr) *depth_scale = m.depth_scale();
  return c;
}

namespace {

void CheckImageMatchesCamera(const cv::Mat& image, const PinholeCamera& camera,
                             const std::string& field) {
  if (image.cols != camera.width || image.rows != camera.height) {
    Fail(field, std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                    " does not match camera " + std::to_string(camera.width) + "x" +
                    std::to_string(camera.height));
  }
}

}  // namespace

msg::RgbdFrame RgbdFrameToMsg(const RgbdFrameData& frame) {
  msg::RgbdFrame m;
  m.header().stamp(TimeToMsg(frame.stamp));
  m.header().frame_id(frame.frame_id);
  m.header().seq(frame.seq);
  m.camera(CameraToMsg(frame.camera, frame.depth_scale));
  m.color(ImageToMsg(frame.rgb));
  m.depth(ImageToMsg(frame.depth));
  return m;
}

RgbdFrameData RgbdFrameFromMsg(const msg::RgbdFrame& m) {
  RgbdFrameData f;
  f.stamp = TimeFromMsg(m.header().stamp(), "RgbdFrame.header.stamp");
  f.seq = m.header().seq();
  f.frame_id = m.header().frame_id();
  f.camera = CameraFromMsg(m.camera(), "RgbdFrame.camera", &f.depth_scale);
  const std::string& ce = m.color().encoding();
  if (ce != "bgr8" && ce != "rgb8" && ce != "mono8") {
    Fail("RgbdFrame.color.encoding", "'" + ce + "', expected bgr8, rgb8 or mono8");
  }
  const std::string& de = m.depth().encoding();
  if (de != "16UC1" && de != "32FC1") {
    Fail("RgbdFrame.depth.encoding", "'" + de + "', expected 16UC1 or 32FC1");
  }
  f.rgb = ImageFromMsg(m.color(), "RgbdFrame.color");
  if (f.rgb.type() == CV_8UC1) cv::cvtColor(f.rgb, f.rgb, cv::COLOR_GRAY2BGR);
  f.depth = ImageFromMsg(m.depth(), "RgbdFrame.depth");
  CheckImageMatchesCamera(f.rgb, f.camera, "RgbdFrame.color");
  CheckImageMatchesCamera(f.depth, f.camera, "RgbdFrame.depth");
  return f;
}

msg::Detection2D DetectionToMsg(const Detection& d) {
  msg::Detection2D m;
  m.x(d.box.x);
  m.y(d.box.y);
  m.w(d.box.width);
  m.h(d.box.height);
  m.class_id(d.class_id);
  m.label(d.label);
  m.score(d.score);
  return m;
}

Detection DetectionFromMsg(const msg::Detection2D& m, const std::string& field) {
  if (!Finite(m.x()) || !Finite(m.y()) || !Finite(m.w()) || !Finite(m.h())) {
    Fail(field + ".box", "non-finite value");
  }
  if (m.w() < 0 || m.h() < 0) Fail(field + ".box", "negative width or height");
  if (!Finite(m.score())) Fail(field + ".score", "non-finite value");
  Detection d;
  d.box = cv::Rect2f(m.x(), m.y(), m.w(), m.h());
  d.class_id = m.class_id();
  d.label = m.label();
  d.score = m.score();
  return d;
}

msg::Detections DetectionsToMsg(const std::vector<Detection>& detections, Timestamp stamp,
                                uint64_t seq, double inference_ms) {
  msg::Detections m;
  m.header().stamp(TimeToMsg(stamp));
  m.header().frame_id("camera");
  m.header().seq(seq);
  m.inference_ms(inference_ms);
  for (const Detection& d : detections) m.detections().push_back(DetectionToMsg(d));
  return m;
}

std::vector<Detection> DetectionsFromMsg(const msg::Detections& m) {
  TimeFromMsg(m.header().stamp(), "Detections.header.stamp");
  std::vector<Detection> result;
  result.reserve(m.detections().size());
  for (size_t i = 0; i < m.detections().size(); ++i) {
    result.push_back(
        DetectionFromMsg(m.detections()[i], "Detections.detections[" + std::to_string(i) + "]"));
  }
  return result;
}

msg::Keyframe KeyframeToMsg(const KeyframeData& k, const PinholeCamera& camera) {
  msg::Keyframe m;
  m.header().stamp(TimeToMsg(k.stamp));
  m.header().frame_id("camera");
  m.header().seq(static_cast<uint64_t>(k.id < 0 ? 0 : k.id));
  m.id(k.id);
  m.world_from_cam(PoseToMsg(k.world_from_cam));
  m.pose_update_only(k.pose_update_only || k.removed);
  m.removed(k.removed);
  m.camera(CameraToMsg(camera, 1.0));
  if (!k.pose_update_only) {
    m.color(ImageToMsg(k.rgb));
    m.depth(ImageToMsg(k.depth));
    m.dynamic_mask(ImageToMsg(k.dynamic_mask));
    m.keypoints().reserve(k.keypoints.size());
    for (size_t i = 0; i < k.keypoints.size(); ++i) {
      const cv::KeyPoint& kp = k.keypoints[i];
      msg::KeyPoint p;
      p.x(kp.pt.x);
      p.y(kp.pt.y);
      p.size(kp.size);
      p.angle(kp.angle);
      p.response(kp.response);
      p.octave(kp.octave);
      p.dynamic(i < k.keypoint_dynamic.size() && k.keypoint_dynamic[i] != 0);
      m.keypoints().push_back(p);
    }
    for (const Detection& d : k.detections) m.detections().push_back(DetectionToMsg(d));
  }
  return m;
}

KeyframeData KeyframeFromMsg(const msg::Keyframe& m, PinholeCamera* camera) {
  KeyframeData k;
  k.id = m.id();
  if (k.id < 0) Fail("Keyframe.id", std::to_string(k.id) + " is negative");
  k.stamp = TimeFromMsg(m.header().stamp(), "Keyframe.header.stamp");
  k.world_from_cam = PoseFromMsg(m.world_from_cam(), "Keyframe.world_from_cam");
  k.removed = m.removed();
  k.pose_update_only = m.pose_update_only() || k.removed;
  const PinholeCamera cam = CameraFromMsg(m.camera(), "Keyframe.camera");
  if (camera != nullptr) *camera = cam;
  if (k.pose_update_only) return k;
  if (m.color().encoding() != "bgr8") {
    Fail("Keyframe.color.encoding", "'" + m.color().encoding() + "', expected bgr8");
  }
  if (m.depth().encoding() != "32FC1") {
    Fail("Keyframe.depth.encoding", "'" + m.depth().encoding() + "', expected 32FC1");
  }
  k.rgb = ImageFromMsg(m.color(), "Keyframe.color");
  k.depth = ImageFromMsg(m.depth(), "Keyframe.depth");
  CheckImageMatchesCamera(k.rgb, cam, "Keyframe.color");
  CheckImageMatchesCamera(k.depth, cam, "Keyframe.depth");
  if (!(m.dynamic_mask().width() == 0 && m.dynamic_mask().data().empty())) {
    if (m.dynamic_mask().encoding() != "mono8") {
      Fail("Keyframe.dynamic_mask.encoding",
           "'" + m.dynamic_mask().encoding() + "', expected mono8");
    }
    k.dynamic_mask = ImageFromMsg(m.dynamic_mask(), "Keyframe.dynamic_mask");
    CheckImageMatchesCamera(k.dynamic_mask, cam, "Keyframe.dynamic_mask");
  }
  k.keypoints.reserve(m.keypoints().size());
  k.keypoint_dynamic.reserve(m.keypoints().size());
  for (size_t i = 0; i < m.keypoints().size(); ++i) {
    const msg::KeyPoint& p = m.keypoints()[i];
    if (!Finite(p.x()) || !Finite(p.y()) || !Finite(p.size()) || !Finite(p.angle()) ||
        !Finite(p.response())) {
      Fail("Keyframe.keypoints[" + std::to_string(i) + "]", "non-finite value");
    }
    k.keypoints.emplace_back(p.x(), p.y(), p.size(), p.angle(), p.response(), p.octave());
    k.keypoint_dynamic.push_back(p.dynamic() ? 1 : 0);
  }
  for (size_t i = 0; i < m.detections().size(); ++i) {
    k.detections.push_back(
        DetectionFromMsg(m.detections()[i], "Keyframe.detections[" + std::to_string(i) + "]"));
  }
  return k;
}

msg::GroundTruthPose GroundTruthToMsg(const StampedPose& pose, uint64_t seq) {
  msg::GroundTruthPose m;
  m.header().stamp(TimeToMsg(pose.stamp));
  m.header().frame_id("world");
  m.header().seq(seq);
  m.world_from_cam(PoseToMsg(pose.world_from_cam));
  return m;
}

StampedPose GroundTruthFromMsg(const msg::GroundTruthPose& m) {
  StampedPose p;
  p.stamp = TimeFromMsg(m.header().stamp(), "GroundTruthPose.header.stamp");
  p.world_from_cam = PoseFromMsg(m.world_from_cam(), "GroundTruthPose.world_from_cam");
  return p;
}

msg::Trajectory TrajectoryToMsg(const std::vector<StampedPose>& poses, bool keyframes_only) {
  msg::Trajectory m;
  m.header().frame_id("world");
  if (!poses.empty()) m.header().stamp(TimeToMsg(poses.back().stamp));
  m.header().seq(poses.size());
  m.keyframes_only(keyframes_only);
  m.poses().reserve(poses.size());
  for (const StampedPose& p : poses) {
    msg::StampedPose s;
    s.stamp(TimeToMsg(p.stamp));
    s.world_from_cam(PoseToMsg(p.world_from_cam));
    m.poses().push_back(s);
  }
  return m;
}

std::vector<StampedPose> TrajectoryFromMsg(const msg::Trajectory& m) {
  std::vector<StampedPose> poses;
  poses.reserve(m.poses().size());
  for (size_t i = 0; i < m.poses().size(); ++i) {
    const std::string field = "Trajectory.poses[" + std::to_string(i) + "]";
    StampedPose p;
    p.stamp = TimeFromMsg(m.poses()[i].stamp(), field + ".stamp");
    p.world_from_cam = PoseFromMsg(m.poses()[i].world_from_cam(), field + ".world_from_cam");
    poses.push_back(p);
  }
  return poses;
}

int64_t StreamFrameCountFromMsg(const msg::StreamStatus& status) {
  constexpr uint64_t kMax = static_cast<uint64_t>(std::numeric_limits<int64_t>::max());
  return static_cast<int64_t>(std::min(status.num_frames(), kMax));
}

}  // namespace dygslam
