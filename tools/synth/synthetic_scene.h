// Synthetic dynamic RGB-D sequences with exact ground truth: a closed, textured room with static
// furniture boxes, seen by an RGB-D camera moving along a smooth known path, with textured
// person-sized boxes walking back and forth on the floor. Everything is analytic (ray casting
// against boxes per pixel), deterministic in the seed and independent of rendering order.
//
// World frame: z up, floor at z = 0, room interior x in [-size.x/2, size.x/2], y in
// [-size.y/2, size.y/2], z in [0, size.z]. Camera frame: x right, y down, z forward (optical axis).
// Depth is the z coordinate of the surface point in the camera frame (not the ray length).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "core/base/camera.h"
#include "core/base/rigid3.h"
#include "core/base/timestamp.h"
#include "core/base/types.h"

namespace dygslam {

// A box centred at the origin of its own frame with the given half extents, placed in the world.
struct OrientedBox {
  Rigid3d world_from_box;
  Eigen::Vector3d half_extents = Eigen::Vector3d::Zero();

  bool Contains(const Eigen::Vector3d& p_world, double margin = 0.0) const;
  // Unsigned Euclidean distance from p to the box's surface (inside or outside).
  double DistanceToSurface(const Eigen::Vector3d& p_world) const;
};

PinholeCamera DefaultSyntheticCamera();  // fx = fy = 525, cx = 319.5, cy = 239.5, 640x480

struct SyntheticOptions {
  PinholeCamera camera = DefaultSyntheticCamera();  // no distortion is rendered; must be zero
  RgbdSensorOptions sensor;                         // fps, bf, ThDepth, DepthMapFactor
  int num_frames = 100;
  int num_moving_objects = 2;  // 0..4 person-sized boxes on parallel lanes in front of the camera
  uint64_t seed = 1;           // textures, object speeds/phases/lanes, noise
  Timestamp start_stamp = Timestamp::FromNanoseconds(1'700'000'000'000'000'000LL);
  // depth.txt stamps = rgb stamp + offset + uniform jitter in [-jitter, jitter] (whole
  // microseconds). Both images show the scene at the rgb stamp (a registered pair).
  double depth_stamp_offset = 0.004;  // seconds
  double depth_stamp_jitter = 0.001;  // seconds

  // Scene.
  Eigen::Vector3d room_size{6.0, 5.0, 3.0};  // metres; at least 5 x 4 x 2.5
  int supersampling = 2;                     // NxN colour samples per pixel (1..4)
  double texels_per_metre = 250.0;           // room textures (furniture x1.2, objects x2)

  // Camera path (sinusoids of time; yaw 0 looks along world +x, positive pitch looks up).
  double camera_height = 1.4;    // metres above the floor
  double path_amplitude = 0.35;  // metres (x; y uses 0.8x, z 0.1 m)
  double path_period = 9.0;      // seconds
  double yaw_amplitude_deg = 35.0;
  double yaw_period = 8.0;  // seconds
  double pitch_offset_deg = -6.0;
  double pitch_amplitude_deg = 8.0;
  double pitch_period = 5.5;  // seconds
  double roll_amplitude_deg = 3.0;
  // Loop path (loop_semi_axes > 0): instead of the sinusoids around one spot, the camera goes
  // round a rounded rectangle centred in the room with these half sizes (x, y; metres) and
  // corner radius, at loop_speed, looking outwards at the walls (at a constant distance on the
  // sides: half the difference of the sizes), starting at (+a, 0) and going anticlockwise; pitch
  // and roll keep their sinusoids. One lap is 4 (a + b) - 8 r + 2 pi r metres (e.g. 12 x 6 m,
  // r = 1.5: 69 m).
  Eigen::Vector2d loop_semi_axes{0.0, 0.0};
  double loop_corner_radius = 1.5;
  double loop_speed = 1.0;  // m/s
  // Inward loop: the camera looks inwards at a floor-to-ceiling pillar in the middle
  // of the room whose corners are the centres of the path's corner arcs (half sizes a - r, b - r),
  // so the surface in view is always r away: on the sides a face of the pillar, at the corners its
  // edge (the camera orbits it). Outward views of a big room put the corners of the room beyond
  // ThDepth (~3 m), where tracking made no keyframes. Needs a - r >= 0.25 and b - r >= 0.25.
  bool loop_inward = false;

  // Moving objects: boxes of object_size (width x depth x height), walking along world y on lanes
  // at increasing distance in front of the camera, back and forth at ~object_speed (+-20 %).
  Eigen::Vector3d object_size{0.5, 0.4, 1.7};
  double object_speed = 1.0;    // m/s
  int objects_start_frame = 0;  // objects are absent (not rendered, not listed) before this frame
  // Harder movers (label tests of the dynamic filter; defaults keep the old sequences):
  // seconds each object stands at each end of its lane (walk, stop, stand, walk back) ...
  double object_pause = 0.0;
  // ... turning round (yaw +180 deg, smoothly) in the second half of each pause.
  bool object_turn = false;
  // The last N lane objects are never reported in `boxes` (a mover the detector misses).
  int num_undetected_objects = 0;
  // > 0: one more mover (reported in boxes, last object index) walking across the view on a
  // short lane this far (metres) in front of the camera path centre: it fills about half the
  // view when it passes. Needs path_amplitude + object_size.x / 2 + 0.3 <= this distance.
  double near_object_distance = 0.0;
  // > 0: a mover that walks along with the camera close in front of it and covers this share of
  // the image (columns from the right edge, the full height) for occluder_frames frames from
  // occluder_start_frame, after sliding in from the right over occluder_ramp_frames (and out
  // again after them): a person in a crowd who fills the view for a while. Its front is
  // occluder_distance in front of the camera, swaying a few centimetres as it walks. It is the
  // last moving object; reported in boxes unless occluder_undetected.
  double occluder_coverage = 0.0;  // 0, or 0.1 .. 0.98
  int occluder_start_frame = 0;
  int occluder_frames = 30;
  int occluder_ramp_frames = 6;
  double occluder_distance = 0.9;  // metres
  bool occluder_undetected = false;

  // Sensor model.
  bool depth_noise = false;
  double depth_noise_coefficient = 0.0015;  // noise std = coefficient * z^2 (metres)
  double rgb_noise_sigma = 0.0;             // Gaussian colour noise (intensity units)
  double min_depth = 0.0;                   // > 0: closer pixels read 0 (invalid)
  double max_depth = 0.0;                   // > 0: farther pixels read 0 (invalid)
  int min_detection_pixels = 150;           // visible pixels needed to report a box

  void Check() const;
};

struct SyntheticFrame {
  int index = 0;
  Timestamp stamp;        // rgb stamp
  Timestamp depth_stamp;  // as written to depth.txt
  Rigid3d world_from_cam;
  cv::Mat rgb;                   // CV_8UC3 BGR
  cv::Mat depth;                 // CV_16UC1, value / DepthMapFactor = metres, 0 = invalid
  cv::Mat dynamic_mask;          // CV_8UC1, 255 where a moving object is visible (pixel centre ray)
  cv::Mat object_labels;         // CV_8UC1, 0 = static scene, k + 1 = moving object k
  std::vector<Detection> boxes;  // visible moving objects: class 0 "person", score 1
  std::vector<int> box_object_ids;  // moving-object index of each box
};

// What a ray through a pixel hits.
struct SyntheticHit {
  enum class Kind { kRoom, kStaticBox, kMovingObject };
  Kind kind = Kind::kRoom;
  int index = 0;       // static box or moving-object index
  int face = 0;        // 0..5: 2 * axis + (positive side ? 1 : 0), in the box frame
  double depth = 0.0;  // z in the camera frame, metres
  Eigen::Vector3d point_world = Eigen::Vector3d::Zero();
};

class SyntheticScene {
 public:
  // Checks the options and builds the textures (a fraction of a second).
  explicit SyntheticScene(const SyntheticOptions& options);

  const SyntheticOptions& options() const { return options_; }
  int num_frames() const { return options_.num_frames; }
  int num_moving_objects() const { return static_cast<int>(objects_.size()); }
  // The occluder's object index, or -1 without one.
  int occluder_index() const;
  // The share of the image columns the occluder covers at `frame` by design (0 when absent).
  double OccluderCoverage(int frame) const;
  // False for the objects of num_undetected_objects (never in boxes).
  bool IsObjectDetected(int object) const { return objects_.at(object).detected; }

  Timestamp FrameStamp(int frame) const;
  Timestamp DepthStamp(int frame) const;
  double FrameTime(int frame) const;  // seconds since the first frame

  Rigid3d WorldFromCamAtTime(double t) const;
  Rigid3d WorldFromCam(int frame) const { return WorldFromCamAtTime(FrameTime(frame)); }

  // Geometry for map tests.
  const OrientedBox& room() const { return room_; }
  const std::vector<OrientedBox>& static_boxes() const { return static_boxes_; }
  bool IsObjectPresent(int object, int frame) const;
  // Pose and extent of moving object `object` at `frame` (also defined when not present).
  OrientedBox MovingObjectBox(int object, int frame) const;
  // True if p lies inside (within margin of) any moving object present at `frame`.
  bool IsInsideMovingObject(const Eigen::Vector3d& p_world, int frame, double margin = 0.0) const;
  // True if p lies inside (within margin of) any moving object at any frame of the sequence.
  bool IsInSweptVolume(const Eigen::Vector3d& p_world, double margin = 0.0) const;
  // Distance from p to the nearest static surface (room walls/floor/ceiling, furniture).
  double DistanceToStaticSurface(const Eigen::Vector3d& p_world) const;
  bool IsStaticSurface(const Eigen::Vector3d& p_world, double tolerance) const {
    return DistanceToStaticSurface(p_world) <= tolerance;
  }

  // Exact ray cast through image point (u, v) (pixel centres at integer coordinates).
  SyntheticHit CastPixel(int frame, double u, double v) const;

  // Renders frame `frame` (0 <= frame < num_frames). Thread-safe (const, no shared state).
  SyntheticFrame RenderFrame(int frame) const;

 private:
  struct MovingObject {
    Eigen::Vector3d lane_start, lane_end;  // centre positions at the two turning points
    double speed = 1.0;
    double phase = 0.0;     // fraction of a back-and-forth cycle at start
    bool detected = true;   // listed in SyntheticFrame::boxes when visible
    bool occluder = false;  // moves with the camera (see SyntheticOptions::occluder_coverage)
    Eigen::Vector3d size = Eigen::Vector3d::Zero();  // box extents (x, y, z)
  };
  // The occluder's box at `frame`, given the camera pose there.
  OrientedBox OccluderBox(const MovingObject& m, int frame) const;
  struct Surface {
    OrientedBox box;
    bool inside = false;  // seen from inside (the room)
    double texels_per_metre = 250.0;
    cv::Mat texture[6];  // per face, CV_8UC3
  };
  struct FrameGeometry;

  FrameGeometry PrepareFrame(int frame) const;

  SyntheticOptions options_;
  OrientedBox room_;
  std::vector<OrientedBox> static_boxes_;
  std::vector<MovingObject> objects_;
  // Surfaces: 0 = room, 1..S = static boxes, then one per moving object (textures only; their
  // pose changes per frame).
  std::vector<Surface> surfaces_;
};

}  // namespace dygslam
