#include "bridge/ros2_convert.h"

#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "core/base/error.h"
#include "core/base/image_encoding.h"

namespace dygslam::ros2 {

namespace {

constexpr uint32_t kMaxSide = 16384;

[[noreturn]] void Fail(const std::string& field, const std::string& what) {
  throw InputError(field + ": " + what);
}

bool AllFinite(const double* v, size_t n) {
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(v[i])) return false;
  }
  return true;
}

// Checks dimensions / step / data size; returns the bytes per pixel.
void CheckLayout(const sensor_msgs::msg::Image& image, int bytes_per_pixel,
                 const std::string& field) {
  if (image.width() == 0 || image.height() == 0 || image.width() > kMaxSide ||
      image.height() > kMaxSide) {
    Fail(field, "image size " + std::to_string(image.width()) + "x" +
                    std::to_string(image.height()) + " outside [1, " + std::to_string(kMaxSide) +
                    "]");
  }
  const uint64_t row = static_cast<uint64_t>(image.width()) * bytes_per_pixel;
  if (image.step() < row) {
    Fail(field + ".step",
         std::to_string(image.step()) + " < width " + std::to_string(image.width()) + " x " +
             std::to_string(bytes_per_pixel) + " bytes (" + image.encoding() + ")");
  }
  const uint64_t needed = static_cast<uint64_t>(image.step()) * image.height();
  if (image.data().size() < needed) {
    Fail(field + ".data", std::to_string(image.data().size()) + " bytes, expected step " +
                              std::to_string(image.step()) + " x height " +
                              std::to_string(image.height()) + " = " + std::to_string(needed));
  }
  if (image.is_bigendian() > 1) {
    Fail(field + ".is_bigendian", "expected 0 or 1, got " + std::to_string(image.is_bigendian()));
  }
}

// A Mat header over the message's rows (no copy; valid while the message lives).
cv::Mat View(const sensor_msgs::msg::Image& image, int type) {
  return cv::Mat(static_cast<int>(image.height()), static_cast<int>(image.width()), type,
                 const_cast<uint8_t*>(image.data().data()), image.step());
}

}  // namespace

builtin_interfaces::msg::Time TimeToRos(Timestamp stamp) {
  builtin_interfaces::msg::Time t;
  int64_t ns = stamp.nanoseconds();
  int64_t sec = ns / 1000000000;
  int64_t rem = ns % 1000000000;
  if (rem < 0) {
    rem += 1000000000;
    sec -= 1;
  }
  t.sec(static_cast<int32_t>(sec));
  t.nanosec(static_cast<uint32_t>(rem));
  return t;
}

Timestamp TimeFromRos(const builtin_interfaces::msg::Time& time, const std::string& field) {
  if (time.nanosec() >= 1000000000u) {
    Fail(field + ".nanosec", std::to_string(time.nanosec()) + " >= 1e9");
  }
  return Timestamp::FromNanoseconds(static_cast<int64_t>(time.sec()) * 1000000000 + time.nanosec());
}

std_msgs::msg::Header HeaderToRos(Timestamp stamp, const std::string& frame_id) {
  std_msgs::msg::Header h;
  h.stamp(TimeToRos(stamp));
  h.frame_id(frame_id);
  return h;
}

namespace {

// cv::cvtColor code of a ROS Bayer encoding (cv_bridge's mapping: OpenCV names a pattern by the
// second row's second and third pixels), -1 if `e` is not one.
int BayerCode(const std::string& e) {
  const std::string p = e.substr(0, 10);
  if (p == "bayer_rggb") return cv::COLOR_BayerBG2BGR;
  if (p == "bayer_bggr") return cv::COLOR_BayerRG2BGR;
  if (p == "bayer_gbrg") return cv::COLOR_BayerGR2BGR;
  if (p == "bayer_grbg") return cv::COLOR_BayerGB2BGR;
  return -1;
}

// 16-bit pixels (byte order per is_bigendian) to 8 bits (the high byte).
cv::Mat HighByte(const sensor_msgs::msg::Image& image) {
  const cv::Mat view = View(image, CV_16UC1);
  cv::Mat out(view.size(), CV_8UC1);
  const int hi = image.is_bigendian() ? 0 : 1;
  for (int r = 0; r < view.rows; ++r) {
    const uint8_t* in = view.ptr<uint8_t>(r);
    uint8_t* o = out.ptr<uint8_t>(r);
    for (int c = 0; c < view.cols; ++c) o[c] = in[2 * c + hi];
  }
  return out;
}

}  // namespace

cv::Mat ColorFromRos(const sensor_msgs::msg::Image& image, const std::string& field) {
  const std::string& e = image.encoding();
  int channels = 0;
  int code = -1;  // cvtColor code, -1 = copy
  bool sixteen_bit = false;
  if (e == "bgr8" || e == "8UC3") {
    channels = 3;
  } else if (e == "rgb8") {
    channels = 3;
    code = cv::COLOR_RGB2BGR;
  } else if (e == "bgra8" || e == "8UC4") {
    channels = 4;
    code = cv::COLOR_BGRA2BGR;
  } else if (e == "rgba8") {
    channels = 4;
    code = cv::COLOR_RGBA2BGR;
  } else if (e == "mono8" || e == "8UC1") {
    channels = 1;
    code = cv::COLOR_GRAY2BGR;
  } else if (e == "mono16") {
    channels = 1;
    sixteen_bit = true;
    code = cv::COLOR_GRAY2BGR;
  } else if (e == "yuv422" || e == "uyvy") {
    channels = 2;
    code = cv::COLOR_YUV2BGR_UYVY;
  } else if (e == "yuv422_yuy2" || e == "yuyv") {
    channels = 2;
    code = cv::COLOR_YUV2BGR_YUY2;
  } else if (BayerCode(e) >= 0 && (e.size() == 11 && e[10] == '8')) {
    channels = 1;
    code = BayerCode(e);
  } else if (BayerCode(e) >= 0 && e.size() == 12 && e.substr(10) == "16") {
    channels = 1;
    sixteen_bit = true;
    code = BayerCode(e);
  } else {
    Fail(field + ".encoding", "'" + e +
                                  "' is not a supported colour encoding (bgr8, rgb8, bgra8, "
                                  "rgba8, mono8, mono16, yuv422, yuv422_yuy2, bayer_rggb8, "
                                  "bayer_bggr8, bayer_gbrg8, bayer_grbg8, bayer_*16)");
  }
  if (channels == 2 && image.width() % 2 != 0) {
    Fail(field + ".width", "odd width " + std::to_string(image.width()) + " for " + e +
                               " (two pixels share one U/V pair)");
  }
  CheckLayout(image, sixteen_bit ? 2 : channels, field);
  if (BayerCode(e) >= 0 && (image.width() < 2 || image.height() < 2)) {
    Fail(field, "a Bayer image needs at least 2x2 pixels");
  }
  const cv::Mat view = sixteen_bit ? HighByte(image) : View(image, CV_8UC(channels));
  cv::Mat out;
  if (code < 0) {
    out = view.clone();
  } else {
    cv::cvtColor(view, out, code);
  }
  return out;
}

DepthImage DepthFromRos(const sensor_msgs::msg::Image& image, double depth_unit,
                        const std::string& field) {
  if (!(depth_unit > 0) || !std::isfinite(depth_unit)) {
    throw InvalidOptions("invalid option depth_unit: requires a positive number of metres");
  }
  const std::string& e = image.encoding();
  DepthImage out;
  if (e == "16UC1" || e == "mono16") {
    CheckLayout(image, 2, field);
    out.depth = View(image, CV_16UC1).clone();
    if (image.is_bigendian()) {
      for (int r = 0; r < out.depth.rows; ++r) {
        auto* row = out.depth.ptr<uint16_t>(r);
        for (int c = 0; c < out.depth.cols; ++c) {
          row[c] = static_cast<uint16_t>((row[c] >> 8) | (row[c] << 8));
        }
      }
    }
    out.depth_scale = 1.0 / depth_unit;
  } else if (e == "32FC1") {
    CheckLayout(image, 4, field);
    out.depth = View(image, CV_32FC1).clone();
    for (int r = 0; r < out.depth.rows; ++r) {
      auto* row = out.depth.ptr<float>(r);
      for (int c = 0; c < out.depth.cols; ++c) {
        float v = row[c];
        if (image.is_bigendian()) {
          uint32_t bits;
          std::memcpy(&bits, &v, 4);
          bits = __builtin_bswap32(bits);
          std::memcpy(&v, &bits, 4);
        }
        row[c] = (std::isfinite(v) && v > 0.f) ? v : 0.f;
      }
    }
    out.depth_scale = 1.0;
  } else {
    Fail(field + ".encoding",
         "'" + e +
             "' is not a supported depth encoding (16UC1 / mono16 = millimetres, 32FC1 = "
             "metres)");
  }
  return out;
}

sensor_msgs::msg::Image ImageToRos(const cv::Mat& image, Timestamp stamp,
                                   const std::string& frame_id) {
  sensor_msgs::msg::Image m;
  m.header(HeaderToRos(stamp, frame_id));
  m.encoding(ImageEncodingOf(image.type(), "ImageToRos"));
  m.width(static_cast<uint32_t>(image.cols));
  m.height(static_cast<uint32_t>(image.rows));
  m.is_bigendian(0);
  m.step(static_cast<uint32_t>(image.cols * image.elemSize()));
  m.data(PackedImageRows(image));
  return m;
}

RosCamera CameraFromRos(const sensor_msgs::msg::CameraInfo& info, const std::string& field) {
  RosCamera out;
  if (info.width() == 0 || info.height() == 0 || info.width() > kMaxSide ||
      info.height() > kMaxSide) {
    Fail(field, "image size " + std::to_string(info.width()) + "x" + std::to_string(info.height()) +
                    " outside [1, " + std::to_string(kMaxSide) + "]");
  }
  const auto& k = info.k();
  if (!AllFinite(k.data(), k.size())) Fail(field + ".k", "non-finite value");
  if (k[0] == 0.0) Fail(field + ".k", "K[0] = 0: uncalibrated camera");
  if (!(k[0] > 0) || !(k[4] > 0)) Fail(field + ".k", "focal lengths K[0], K[4] must be > 0");
  if (info.binning_x() > 1 || info.binning_y() > 1) {
    Fail(field + ".binning_x/binning_y", "binning " + std::to_string(info.binning_x()) + "x" +
                                             std::to_string(info.binning_y()) +
                                             " is not supported");
  }
  const auto& roi = info.roi();
  if (roi.width() != 0 && roi.height() != 0 &&
      (roi.x_offset() != 0 || roi.y_offset() != 0 || roi.width() != info.width() ||
       roi.height() != info.height())) {
    Fail(field + ".roi", "a region of interest smaller than the image is not supported");
  }
  PinholeCamera& c = out.camera;
  c.width = static_cast<int>(info.width());
  c.height = static_cast<int>(info.height());
  c.fx = k[0];
  c.fy = k[4];
  c.cx = k[2];
  c.cy = k[5];
  const std::vector<double>& d = info.d();
  if (!AllFinite(d.data(), d.size())) Fail(field + ".d", "non-finite coefficient");
  const std::string& model = info.distortion_model();
  size_t count = 0;
  if (model == "plumb_bob") {
    out.model = DistortionModel::kPlumbBob;
    count = 5;
  } else if (model == "rational_polynomial") {
    out.model = DistortionModel::kRationalPolynomial;
    count = 8;
  } else if (model == "equidistant") {
    out.model = DistortionModel::kEquidistant;
    count = 4;
  } else if ((model.empty() || model == "none") && d.empty()) {
    out.model = DistortionModel::kNone;
  } else {
    Fail(field + ".distortion_model",
         "'" + model + "' is not supported (plumb_bob, rational_polynomial, equidistant)");
  }
  if (d.size() > count) {
    Fail(field + ".d", std::to_string(d.size()) + " coefficients for '" + model + "' (at most " +
                           std::to_string(count) + ")");
  }
  out.coefficients.assign(count, 0.0);
  std::copy(d.begin(), d.end(), out.coefficients.begin());
  if (out.model == DistortionModel::kEquidistant) {
    out.rectify = std::any_of(d.begin(), d.end(), [](double v) { return v != 0.0; });
  } else if (out.model == DistortionModel::kRationalPolynomial) {
    out.rectify = std::any_of(d.begin() + std::min<size_t>(5, d.size()), d.end(),
                              [](double v) { return v != 0.0; });
  }
  if (!out.rectify && count >= 5) {
    c.k1 = out.coefficients[0];
    c.k2 = out.coefficients[1];
    c.p1 = out.coefficients[2];
    c.p2 = out.coefficients[3];
    c.k3 = out.coefficients[4];
  }
  return out;
}

bool RosCamera::operator==(const RosCamera& o) const {
  const PinholeCamera& a = camera;
  const PinholeCamera& b = o.camera;
  return model == o.model && coefficients == o.coefficients && rectify == o.rectify &&
         a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy &&
         a.cx == b.cx && a.cy == b.cy && a.k1 == b.k1 && a.k2 == b.k2 && a.p1 == b.p1 &&
         a.p2 == b.p2 && a.k3 == b.k3;
}

ImageRectifier::ImageRectifier(const RosCamera& c) {
  if (!c.rectify) return;
  const cv::Mat k = c.camera.K();
  const cv::Size size(c.camera.width, c.camera.height);
  const cv::Mat d(c.coefficients, true);
  if (c.model == DistortionModel::kEquidistant) {
    cv::fisheye::initUndistortRectifyMap(k, d, cv::Mat::eye(3, 3, CV_64F), k, size, CV_32FC1,
                                         map_x_, map_y_);
  } else {
    cv::initUndistortRectifyMap(k, d, cv::Mat::eye(3, 3, CV_64F), k, size, CV_32FC1, map_x_,
                                map_y_);
  }
}

cv::Mat ImageRectifier::Color(const cv::Mat& image) const {
  if (!active()) return image;
  cv::Mat out;
  cv::remap(image, out, map_x_, map_y_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  return out;
}

cv::Mat ImageRectifier::Depth(const cv::Mat& depth) const {
  if (!active()) return depth;
  cv::Mat out;
  cv::remap(depth, out, map_x_, map_y_, cv::INTER_NEAREST, cv::BORDER_CONSTANT);
  return out;
}

void CheckFrameId(const std::string& frame_id, const std::string& field) {
  if (!frame_id.empty() && frame_id[0] == '/') {
    Fail(field, "frame id '" + frame_id +
                    "' starts with '/': tf2 refuses such ids (ROS 2 frame ids have no leading "
                    "'/'; fix the driver's frame_id parameter)");
  }
}

sensor_msgs::msg::CameraInfo CameraToRos(const PinholeCamera& c, Timestamp stamp,
                                         const std::string& frame_id) {
  sensor_msgs::msg::CameraInfo m;
  m.header(HeaderToRos(stamp, frame_id));
  m.width(static_cast<uint32_t>(c.width));
  m.height(static_cast<uint32_t>(c.height));
  m.distortion_model("plumb_bob");
  m.d({c.k1, c.k2, c.p1, c.p2, c.k3});
  m.k({c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1});
  m.r({1, 0, 0, 0, 1, 0, 0, 0, 1});
  m.p({c.fx, 0, c.cx, 0, 0, c.fy, c.cy, 0, 0, 0, 1, 0});
  return m;
}

Rigid3d MapFromWorld(bool ros_axes) {
  if (!ros_axes) return Rigid3d::Identity();
  // Columns: the optical axes x (right), y (down), z (forward) in REP 103 map axes.
  Eigen::Matrix3d r;
  r << 0, 0, 1,  //
      -1, 0, 0,  //
      0, -1, 0;
  return Rigid3d(r, Eigen::Vector3d::Zero());
}

geometry_msgs::msg::Pose PoseToRos(const Rigid3d& pose) {
  geometry_msgs::msg::Pose m;
  m.position().x(pose.translation.x());
  m.position().y(pose.translation.y());
  m.position().z(pose.translation.z());
  const Eigen::Quaterniond q = pose.rotation.normalized();
  m.orientation().x(q.x());
  m.orientation().y(q.y());
  m.orientation().z(q.z());
  m.orientation().w(q.w());
  return m;
}

Rigid3d PoseFromRos(const geometry_msgs::msg::Pose& p) {
  return Rigid3d(Eigen::Quaterniond(p.orientation().w(), p.orientation().x(), p.orientation().y(),
                                    p.orientation().z()),
                 Eigen::Vector3d(p.position().x(), p.position().y(), p.position().z()));
}

geometry_msgs::msg::PoseStamped PoseStampedToRos(const Rigid3d& pose, Timestamp stamp,
                                                 const std::string& frame_id) {
  geometry_msgs::msg::PoseStamped m;
  m.header(HeaderToRos(stamp, frame_id));
  m.pose(PoseToRos(pose));
  return m;
}

nav_msgs::msg::Path PathToRos(const std::vector<StampedPose>& poses, const Rigid3d& map_from_world,
                              Timestamp stamp, const std::string& frame_id) {
  nav_msgs::msg::Path m;
  m.header(HeaderToRos(stamp, frame_id));
  m.poses().reserve(poses.size());
  for (const StampedPose& p : poses) {
    m.poses().push_back(PoseStampedToRos(map_from_world * p.world_from_cam, p.stamp, frame_id));
  }
  return m;
}

geometry_msgs::msg::TransformStamped TransformToRos(const Rigid3d& parent_from_child,
                                                    Timestamp stamp, const std::string& parent,
                                                    const std::string& child) {
  geometry_msgs::msg::TransformStamped m;
  m.header(HeaderToRos(stamp, parent));
  m.child_frame_id(child);
  const geometry_msgs::msg::Pose p = PoseToRos(parent_from_child);
  m.transform().translation().x(p.position().x());
  m.transform().translation().y(p.position().y());
  m.transform().translation().z(p.position().z());
  m.transform().rotation(p.orientation());
  return m;
}

nav_msgs::msg::Odometry OdometryToRos(const StampedPose& current,
                                      const std::optional<StampedPose>& previous,
                                      const std::string& frame_id,
                                      const std::string& child_frame_id) {
  nav_msgs::msg::Odometry m;
  m.header(HeaderToRos(current.stamp, frame_id));
  m.child_frame_id(child_frame_id);
  m.pose().pose(PoseToRos(current.world_from_cam));
  if (previous) {
    const double dt = SecondsBetween(previous->stamp, current.stamp);
    if (dt > 0) {
      // prev_from_cur, expressed in the current (child) frame: v = R_cur^T (t_cur - t_prev) / dt.
      const Rigid3d& a = previous->world_from_cam;
      const Rigid3d& b = current.world_from_cam;
      const Eigen::Vector3d v = b.rotation.conjugate() * (b.translation - a.translation) / dt;
      const Eigen::AngleAxisd delta(a.rotation.conjugate() * b.rotation);
      // The axis of prev_from_cur is the same in both camera frames (it is fixed by the
      // rotation), so this is the angular velocity in the current frame.
      const Eigen::Vector3d w = delta.axis() * delta.angle() / dt;
      m.twist().twist().linear().x(v.x());
      m.twist().twist().linear().y(v.y());
      m.twist().twist().linear().z(v.z());
      m.twist().twist().angular().x(w.x());
      m.twist().twist().angular().y(w.y());
      m.twist().twist().angular().z(w.z());
    }
  }
  return m;
}

vision_msgs::msg::Detection2DArray DetectionsToRos(const std::vector<Detection>& detections,
                                                   Timestamp stamp, const std::string& frame_id) {
  vision_msgs::msg::Detection2DArray m;
  m.header(HeaderToRos(stamp, frame_id));
  for (size_t i = 0; i < detections.size(); ++i) {
    const Detection& d = detections[i];
    vision_msgs::msg::Detection2D out;
    out.header(m.header());
    vision_msgs::msg::ObjectHypothesisWithPose h;
    h.hypothesis().class_id(d.label.empty() ? std::to_string(d.class_id) : d.label);
    h.hypothesis().score(d.score);
    h.pose().pose().orientation().w(1.0);
    out.results().push_back(h);
    out.bbox().center().position().x(d.box.x + d.box.width * 0.5);
    out.bbox().center().position().y(d.box.y + d.box.height * 0.5);
    out.bbox().center().theta(0.0);
    out.bbox().size_x(d.box.width);
    out.bbox().size_y(d.box.height);
    out.id(std::to_string(i));
    m.detections().push_back(std::move(out));
  }
  return m;
}

octomap_msgs::msg::Octomap OctomapToRos(const std::vector<uint8_t>& bt_stream, Timestamp stamp,
                                        const std::string& frame_id) {
  std::istringstream in(std::string(bt_stream.begin(), bt_stream.end()));
  octomap::OcTree tree(0.1);
  if (bt_stream.empty() || !tree.readBinary(in)) {
    throw InputError("MapUpdate.octree_bt: not a readable binary OcTree (.bt) stream (" +
                     std::to_string(bt_stream.size()) + " bytes)");
  }
  // The node data as OcTree::writeBinaryData writes it, without the library's progress line on
  // stderr for every map forwarded.
  std::ostringstream out;
  if (tree.getRoot() != nullptr) tree.writeBinaryNode(out, tree.getRoot());
  if (!out) {
    throw InputError("MapUpdate.octree_bt: the octree cannot be serialised");
  }
  const std::string data = out.str();
  octomap_msgs::msg::Octomap m;
  m.header(HeaderToRos(stamp, frame_id));
  m.binary(true);
  m.id(tree.getTreeType());
  m.resolution(tree.getResolution());
  m.data().resize(data.size());
  std::memcpy(m.data().data(), data.data(), data.size());
  return m;
}

}  // namespace dygslam::ros2
