#include "tools/synth/box_room.h"

#include <cmath>
#include <limits>

namespace dygslam::box_room {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Slab test; returns entry (near) and exit (far) distances along the ray.
bool IntersectBox(const Box& box, const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                  double* near, double* far) {
  double t0 = -kInf, t1 = kInf;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(dir[a]) < 1e-12) {
      if (origin[a] < box.min[a] || origin[a] > box.max[a]) return false;
      continue;
    }
    double ta = (box.min[a] - origin[a]) / dir[a];
    double tb = (box.max[a] - origin[a]) / dir[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  if (t0 > t1) return false;
  *near = t0;
  *far = t1;
  return true;
}

}  // namespace

Scene DefaultRoom() {
  Scene scene;
  scene.room = {{-2.52, -2.02, -0.02}, {2.52, 2.02, 2.48}};
  scene.static_boxes.push_back({{1.52, -1.52, -0.02}, {2.02, -0.98, 0.88}});  // cabinet
  scene.static_boxes.push_back({{-0.98, 1.62, -0.02}, {0.02, 2.02, 1.48}});   // shelf
  return scene;
}

PinholeCamera SmallCamera() {
  PinholeCamera camera;
  camera.fx = camera.fy = 120;
  camera.cx = 79.5;
  camera.cy = 59.5;
  camera.width = 160;
  camera.height = 120;
  return camera;
}

Rigid3d LookingAlong(const Eigen::Vector3d& position, double yaw) {
  const Eigen::Vector3d forward(std::cos(yaw), std::sin(yaw), 0);
  const Eigen::Vector3d up(0, 0, 1);
  const Eigen::Vector3d right = forward.cross(up);
  Eigen::Matrix3d rotation;
  rotation.col(0) = right;    // camera x
  rotation.col(1) = -up;      // camera y (down)
  rotation.col(2) = forward;  // camera z
  return Rigid3d(rotation, position);
}

void Render(const Scene& scene, const PinholeCamera& camera, const Rigid3d& world_from_cam,
            cv::Mat* depth, cv::Mat* dynamic_mask) {
  *depth = cv::Mat::zeros(camera.height, camera.width, CV_32FC1);
  *dynamic_mask = cv::Mat::zeros(camera.height, camera.width, CV_8UC1);
  const Eigen::Matrix3d rotation = world_from_cam.RotationMatrix();
  const Eigen::Vector3d origin = world_from_cam.translation;
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      // Ray with unit z in the camera frame: the hit distance along it is the depth.
      const Eigen::Vector3d dir_cam((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0);
      const Eigen::Vector3d dir = rotation * dir_cam;
      double near, far;
      double best = kInf;
      bool dynamic = false;
      if (IntersectBox(scene.room, origin, dir, &near, &far) && far > 0) best = far;
      for (const Box& box : scene.static_boxes) {
        if (IntersectBox(box, origin, dir, &near, &far) && near > 0 && near < best) best = near;
      }
      for (const Box& box : scene.dynamic_boxes) {
        if (IntersectBox(box, origin, dir, &near, &far) && near > 0 && near < best) {
          best = near;
          dynamic = true;
        }
      }
      if (std::isfinite(best)) depth->at<float>(v, u) = static_cast<float>(best);
      if (dynamic) dynamic_mask->at<uint8_t>(v, u) = 255;
    }
  }
}

KeyframeData MakeKeyframe(int64_t id, const Scene& scene, const PinholeCamera& camera,
                          const Rigid3d& world_from_cam) {
  KeyframeData keyframe;
  keyframe.id = id;
  keyframe.stamp = Timestamp::FromNanoseconds(1'000'000'000LL + id * 33'333'333LL);
  keyframe.world_from_cam = world_from_cam;
  Render(scene, camera, world_from_cam, &keyframe.depth, &keyframe.dynamic_mask);
  return keyframe;
}

}  // namespace dygslam::box_room
