// Conversions between ROS 2 messages (bridge/idl, generated with fastddsgen -typeros2) and the
// library types. No DDS entities here.
//
// Conventions:
// - Inbound images: colour "bgr8" / "rgb8" / "bgra8" / "rgba8" / "mono8" (and "8UC3" = bgr8,
//   "8UC1" = mono8), "mono16" (IR / grey cameras: the high byte), "yuv422" (UYVY, the ROS 2
//   name) / "yuv422_yuy2" (YUYV), "bayer_rggb8" / "bayer_bggr8" / "bayer_gbrg8" / "bayer_grbg8"
//   and their 16-bit forms (demosaiced with cv::cvtColor, as cv_bridge) -> CV_8UC3 BGR. Depth
//   "16UC1" / "mono16" -> CV_16UC1 raw counts with depth_scale = 1 / depth_unit (ROS: millimetres,
//   depth_unit 0.001 -> depth_scale 1000; NOT the TUM / Bonn factor 5000), "32FC1" -> CV_32FC1
//   metres (NaN / inf / negative -> 0 = no measurement). is_bigendian = 1 is honoured. Rows may be
//   padded (step > width x bytes per pixel).
// - Outbound geometry: the SLAM world frame is the first camera's optical frame (x right, y down,
//   z forward). With ros_axes the `map` frame is REP 103 (x forward, y left, z up):
//   map_from_world = MapFromWorld(true); the camera frame stays an optical frame.
// Every *FromRos function throws dygslam::InputError naming the field ("<topic>.step: ...").
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "builtin_interfaces/msg/Time.h"
#include "core/base/camera.h"
#include "core/base/rigid3.h"
#include "core/base/timestamp.h"
#include "core/base/types.h"
#include "geometry_msgs/msg/Pose.h"
#include "geometry_msgs/msg/PoseStamped.h"
#include "geometry_msgs/msg/TransformStamped.h"
#include "nav_msgs/msg/Odometry.h"
#include "nav_msgs/msg/Path.h"
#include "octomap_msgs/msg/Octomap.h"
#include "sensor_msgs/msg/CameraInfo.h"
#include "sensor_msgs/msg/Image.h"
#include "std_msgs/msg/Header.h"
#include "vision_msgs/msg/Detection2DArray.h"

namespace dygslam::ros2 {

builtin_interfaces::msg::Time TimeToRos(Timestamp stamp);
// Rejects nanosec >= 1e9.
Timestamp TimeFromRos(const builtin_interfaces::msg::Time& time, const std::string& field);
std_msgs::msg::Header HeaderToRos(Timestamp stamp, const std::string& frame_id);

// Colour image -> CV_8UC3 BGR (deep copy).
cv::Mat ColorFromRos(const sensor_msgs::msg::Image& image, const std::string& field);

struct DepthImage {
  cv::Mat depth;             // CV_16UC1 raw counts or CV_32FC1 metres
  double depth_scale = 1.0;  // raw / depth_scale = metres (1 for CV_32FC1)
};
// depth_unit: metres per 16-bit count (ROS: 0.001).
DepthImage DepthFromRos(const sensor_msgs::msg::Image& image, double depth_unit,
                        const std::string& field);

// Tightly packed little-endian image from a Mat (CV_8UC3 -> "bgr8", CV_8UC1 -> "mono8",
// CV_16UC1 -> "16UC1", CV_32FC1 -> "32FC1").
sensor_msgs::msg::Image ImageToRos(const cv::Mat& image, Timestamp stamp,
                                   const std::string& frame_id);

enum class DistortionModel { kNone, kPlumbBob, kRationalPolynomial, kEquidistant };

struct RosCamera {
  // What the pipeline gets: K, and k1 k2 p1 p2 k3 unless the bridge rectifies.
  PinholeCamera camera;
  DistortionModel model = DistortionModel::kNone;
  // D as received, padded with zeros: 5 (plumb_bob), 8 (rational_polynomial k1 k2 p1 p2 k3 k4 k5
  // k6, OpenCV's order), 4 (equidistant k1 k2 k3 k4, OpenCV's fisheye model).
  std::vector<double> coefficients;
  // The model is not the pipeline's (k1 k2 p1 p2 k3): equidistant, or rational_polynomial with a
  // non-zero k4..k6. The images are then rectified (ImageRectifier) to `camera`: the same K and
  // no distortion, so the SLAM settings need Camera.k1..k3 = p1 = p2 = 0.
  bool rectify = false;
  bool operator==(const RosCamera& o) const;
};
// K (fx, fy, cx, cy), D by distortion_model: "plumb_bob" (k1 k2 p1 p2 k3, shorter lists padded
// with 0), "rational_polynomial" (up to 8), "equidistant" (up to 4), "" / "none" with no
// coefficients. Rejects uncalibrated (K[0] == 0), non-finite values, other models, binning > 1
// and a region of interest smaller than the image.
RosCamera CameraFromRos(const sensor_msgs::msg::CameraInfo& info, const std::string& field);
// Undistorts images of a RosCamera with rectify = true to its pinhole `camera` (same K): all 8
// rational_polynomial coefficients (cv::initUndistortRectifyMap) or the equidistant model
// (cv::fisheye::initUndistortRectifyMap). Maps are computed once. Without rectify it is the
// identity (the images are returned as they are).
class ImageRectifier {
 public:
  explicit ImageRectifier(const RosCamera& camera);
  bool active() const { return !map_x_.empty(); }
  cv::Mat Color(const cv::Mat& image) const;  // bilinear
  cv::Mat Depth(const cv::Mat& depth) const;  // nearest (no depth mixed across edges)

 private:
  cv::Mat map_x_, map_y_;
};

// A ROS frame id for tf2: tf2 refuses ids with a leading '/'. Throws InputError naming `field`.
void CheckFrameId(const std::string& frame_id, const std::string& field);

sensor_msgs::msg::CameraInfo CameraToRos(const PinholeCamera& camera, Timestamp stamp,
                                         const std::string& frame_id);

// REP 103 map axes from the optical SLAM world axes (ros_axes), or identity.
Rigid3d MapFromWorld(bool ros_axes);

geometry_msgs::msg::Pose PoseToRos(const Rigid3d& pose);
Rigid3d PoseFromRos(const geometry_msgs::msg::Pose& pose);
geometry_msgs::msg::PoseStamped PoseStampedToRos(const Rigid3d& pose, Timestamp stamp,
                                                 const std::string& frame_id);
// Poses are world_from_cam; the path holds map_from_world * world_from_cam in frame_id.
nav_msgs::msg::Path PathToRos(const std::vector<StampedPose>& poses, const Rigid3d& map_from_world,
                              Timestamp stamp, const std::string& frame_id);
geometry_msgs::msg::TransformStamped TransformToRos(const Rigid3d& parent_from_child,
                                                    Timestamp stamp, const std::string& parent,
                                                    const std::string& child);
// Odometry of the camera: pose = map_from_cam in frame_id; twist in child_frame_id (the camera
// frame, REP 105) from the previous pose by finite differences (zero without a previous pose or
// for dt <= 0). Covariances are zero (unknown).
nav_msgs::msg::Odometry OdometryToRos(const StampedPose& map_from_cam,
                                      const std::optional<StampedPose>& previous,
                                      const std::string& frame_id,
                                      const std::string& child_frame_id);

// One Detection2D per box: results = [{class_id = label (or the class number), score}],
// bbox centre = box centre, size = box size (pixels), theta 0, id = index.
vision_msgs::msg::Detection2DArray DetectionsToRos(const std::vector<Detection>& detections,
                                                   Timestamp stamp, const std::string& frame_id);

// octomap_msgs/Octomap (binary = true, id "OcTree") from a whole .bt stream (what
// OcTree::writeBinary produces, header included). The message data is the tree data only, as
// octomap_msgs::binaryMapToMsg writes it (read back with OcTree::readBinaryData). Throws
// InputError if the stream is not a readable .bt octree.
octomap_msgs::msg::Octomap OctomapToRos(const std::vector<uint8_t>& bt_stream, Timestamp stamp,
                                        const std::string& frame_id);

}  // namespace dygslam::ros2
