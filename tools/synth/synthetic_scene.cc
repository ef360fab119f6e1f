#include "tools/synth/synthetic_scene.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/base/error.h"
#include "tools/synth/procedural_texture.h"
#include "tools/synth/random.h"

namespace dygslam {
namespace {

constexpr double kPi = 3.141592653589793;
constexpr double kDeg = kPi / 180.0;
constexpr double kInf = std::numeric_limits<double>::infinity();

Eigen::Quaterniond Yaw(double radians) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(radians, Eigen::Vector3d::UnitZ()));
}

OrientedBox MakeBox(const Eigen::Vector3d& centre, const Eigen::Vector3d& half, double yaw_deg) {
  OrientedBox box;
  box.world_from_box = Rigid3d(Yaw(yaw_deg * kDeg), centre);
  box.half_extents = half;
  return box;
}

// Centre x of the camera path and the lane range of the moving objects (see Check()).
double CameraBaseX(const SyntheticOptions& o) { return -o.room_size.x() / 2 + 2.1; }
double NearLaneX(const SyntheticOptions& o) { return CameraBaseX(o) + 1.3; }
double FarLaneX(const SyntheticOptions& o) { return o.room_size.x() / 2 - 1.1; }

}  // namespace

bool OrientedBox::Contains(const Eigen::Vector3d& p_world, double margin) const {
  const Eigen::Vector3d local = world_from_box.Inverse() * p_world;
  return (local.cwiseAbs() - half_extents).maxCoeff() <= margin;
}

double OrientedBox::DistanceToSurface(const Eigen::Vector3d& p_world) const {
  const Eigen::Vector3d local = world_from_box.Inverse() * p_world;
  const Eigen::Vector3d q = local.cwiseAbs() - half_extents;
  const double outside = q.cwiseMax(0.0).norm();
  if (outside > 0) return outside;
  return -q.maxCoeff();
}

PinholeCamera DefaultSyntheticCamera() {
  PinholeCamera camera;
  camera.fx = camera.fy = 525.0;
  camera.cx = 319.5;
  camera.cy = 239.5;
  camera.width = 640;
  camera.height = 480;
  return camera;
}

void SyntheticOptions::Check() const {
  camera.Check();
  sensor.Check();
  DYGSLAM_CHECK_OPTION(!camera.HasDistortion(), "camera distortion (must be zero: not rendered)");
  DYGSLAM_CHECK_OPTION(num_frames >= 1 && num_frames <= 1000000, "num_frames");
  DYGSLAM_CHECK_OPTION(num_moving_objects >= 0 && num_moving_objects <= 4, "num_moving_objects");
  DYGSLAM_CHECK_OPTION(std::abs(depth_stamp_offset) + depth_stamp_jitter < 0.4 / sensor.fps,
                       "depth_stamp_offset/depth_stamp_jitter (|offset| + jitter < 0.4 / fps)");
  DYGSLAM_CHECK_OPTION(depth_stamp_jitter >= 0, "depth_stamp_jitter");
  DYGSLAM_CHECK_OPTION(room_size.allFinite() && room_size.x() >= 5.0 && room_size.y() >= 4.0 &&
                           room_size.z() >= 2.5 && room_size.maxCoeff() <= 50.0,
                       "room_size (at least 5 x 4 x 2.5 m)");
  DYGSLAM_CHECK_OPTION(supersampling >= 1 && supersampling <= 4, "supersampling");
  DYGSLAM_CHECK_OPTION(texels_per_metre >= 50 && texels_per_metre <= 1000, "texels_per_metre");
  DYGSLAM_CHECK_OPTION(camera_height >= 0.5 && camera_height <= room_size.z() - 0.5,
                       "camera_height");
  DYGSLAM_CHECK_OPTION(path_amplitude >= 0 && path_amplitude <= 0.6, "path_amplitude");
  DYGSLAM_CHECK_OPTION(path_period > 0 && yaw_period > 0 && pitch_period > 0,
                       "path_period/yaw_period/pitch_period");
  DYGSLAM_CHECK_OPTION(std::abs(yaw_amplitude_deg) <= 90, "yaw_amplitude_deg");
  DYGSLAM_CHECK_OPTION(std::abs(pitch_offset_deg) + std::abs(pitch_amplitude_deg) <= 45,
                       "pitch_offset_deg/pitch_amplitude_deg");
  DYGSLAM_CHECK_OPTION(std::abs(roll_amplitude_deg) <= 20, "roll_amplitude_deg");
  DYGSLAM_CHECK_OPTION(loop_semi_axes.allFinite() && loop_semi_axes.minCoeff() >= 0 &&
                           (loop_semi_axes.x() == 0) == (loop_semi_axes.y() == 0) &&
                           loop_semi_axes.x() + 1.0 <= room_size.x() / 2 &&
                           loop_semi_axes.y() + 1.0 <= room_size.y() / 2,
                       "loop_semi_axes (both zero, or both positive and 1 m inside the walls)");
  DYGSLAM_CHECK_OPTION(loop_corner_radius > 0 && std::isfinite(loop_corner_radius),
                       "loop_corner_radius");
  DYGSLAM_CHECK_OPTION(loop_speed > 0 && loop_speed <= 5 && std::isfinite(loop_speed),
                       "loop_speed");
  DYGSLAM_CHECK_OPTION(!loop_inward || (loop_semi_axes.x() - loop_corner_radius >= 0.25 &&
                                        loop_semi_axes.y() - loop_corner_radius >= 0.25),
                       "loop_inward (needs a loop path whose half sizes exceed the corner radius "
                       "by at least 0.25 m: the pillar's half sizes)");
  DYGSLAM_CHECK_OPTION(object_size.allFinite() && object_size.minCoeff() >= 0.1 &&
                           object_size.x() <= 1.0 && object_size.y() <= 1.0 &&
                           object_size.z() <= room_size.z() - 0.2,
                       "object_size");
  const double lane_span = FarLaneX(*this) - NearLaneX(*this);
  DYGSLAM_CHECK_OPTION(
      num_moving_objects <= 1 || lane_span / (num_moving_objects - 1) >= object_size.x() + 0.02,
      "num_moving_objects/object_size (lanes would overlap in this room)");
  DYGSLAM_CHECK_OPTION(object_speed > 0 && object_speed <= 5, "object_speed");
  DYGSLAM_CHECK_OPTION(objects_start_frame >= 0, "objects_start_frame");
  DYGSLAM_CHECK_OPTION(object_pause >= 0 && object_pause <= 60, "object_pause");
  DYGSLAM_CHECK_OPTION(num_undetected_objects >= 0 && num_undetected_objects <= num_moving_objects,
                       "num_undetected_objects (at most num_moving_objects)");
  DYGSLAM_CHECK_OPTION(
      near_object_distance == 0 ||
          (near_object_distance >= path_amplitude + object_size.x() / 2 + 0.3 &&
           near_object_distance + object_size.x() + 0.02 <= NearLaneX(*this) - CameraBaseX(*this)),
      "near_object_distance (0, or clear of the camera path and of the first lane)");
  DYGSLAM_CHECK_OPTION(
      occluder_coverage == 0 || (occluder_coverage >= 0.1 && occluder_coverage <= 0.98),
      "occluder_coverage (0, or 0.1 .. 0.98)");
  DYGSLAM_CHECK_OPTION(
      occluder_start_frame >= 0 && occluder_frames >= 1 && occluder_ramp_frames >= 0,
      "occluder_start_frame/occluder_frames/occluder_ramp_frames");
  DYGSLAM_CHECK_OPTION(occluder_distance >= 0.4 && occluder_distance <= 2.0,
                       "occluder_distance (0.4 .. 2 m)");
  DYGSLAM_CHECK_OPTION(depth_noise_coefficient >= 0 && depth_noise_coefficient < 0.1,
                       "depth_noise_coefficient");
  DYGSLAM_CHECK_OPTION(rgb_noise_sigma >= 0 && rgb_noise_sigma <= 50, "rgb_noise_sigma");
  DYGSLAM_CHECK_OPTION(
      min_depth >= 0 && max_depth >= 0 && (max_depth == 0 || max_depth > min_depth),
      "min_depth/max_depth");
  DYGSLAM_CHECK_OPTION(min_detection_pixels >= 1, "min_detection_pixels");
}

// ---------------------------------------------------------------------------------------------
// Construction

SyntheticScene::SyntheticScene(const SyntheticOptions& options) : options_(options) {
  options_.Check();
  const double hx = options_.room_size.x() / 2, hy = options_.room_size.y() / 2;
  const double hz = options_.room_size.z() / 2;
  room_ = MakeBox({0, 0, hz}, {hx, hy, hz}, 0.0);

  // Furniture along the walls, clear of the camera path and of the object lanes.
  static_boxes_ = {
      MakeBox({hx - 0.25, -hy + 1.15, 0.95}, {0.22, 0.45, 0.95}, 0.0),   // cabinet
      MakeBox({hx - 0.40, hy - 1.10, 0.375}, {0.35, 0.60, 0.375}, 0.0),  // table
      MakeBox({hx - 0.35, 0.10, 0.25}, {0.25, 0.30, 0.25}, 15.0),        // crate
      MakeBox({hx - 0.45, hy - 1.00, 0.90}, {0.15, 0.20, 0.15}, -25.0),  // box on the table
      MakeBox({-hx + 2.20, hy - 0.30, 0.40}, {0.70, 0.28, 0.40}, 0.0),   // desk
      MakeBox({-hx + 1.80, -hy + 0.22, 0.80}, {0.50, 0.20, 0.80}, 0.0),  // shelf
  };
  if (options_.loop_inward) {  // the pillar the inward loop goes round (see the options)
    const double r = options_.loop_corner_radius;
    static_boxes_.push_back(MakeBox(
        {0, 0, hz}, {options_.loop_semi_axes.x() - r, options_.loop_semi_axes.y() - r, hz - 0.001},
        0.0));
  }

  SynthRng rng(MixSeed(options_.seed, 0x0B1Eu));
  const int k = options_.num_moving_objects;
  for (int i = 0; i < k; ++i) {
    MovingObject object;
    const double x =
        k == 1 ? 0.5 * (NearLaneX(options_) + FarLaneX(options_))
               : NearLaneX(options_) + (FarLaneX(options_) - NearLaneX(options_)) * i / (k - 1);
    const double y_extent = hy - 0.8;
    const double z = options_.object_size.z() / 2;
    object.lane_start = {x, -y_extent + rng.Uniform(0.0, 0.3), z};
    object.lane_end = {x, y_extent - rng.Uniform(0.0, 0.3), z};
    object.speed = options_.object_speed * rng.Uniform(0.8, 1.2);
    object.phase = rng.Uniform();
    object.detected = i < k - options_.num_undetected_objects;
    object.size = options_.object_size;
    objects_.push_back(object);
  }
  if (options_.near_object_distance > 0) {
    MovingObject object;
    const double x = CameraBaseX(options_) + options_.near_object_distance;
    const double z = options_.object_size.z() / 2;
    object.lane_start = {x, -1.2, z};
    object.lane_end = {x, 1.2, z};
    object.speed = options_.object_speed * rng.Uniform(0.8, 1.2);
    object.phase = rng.Uniform();
    object.size = options_.object_size;
    objects_.push_back(object);
  }
  if (options_.occluder_coverage > 0) {
    // Wide and tall enough to cover the image from its left edge to beyond the right border at
    // any coverage, with room for the sway; 0.3 m deep.
    MovingObject object;
    object.occluder = true;
    object.detected = !options_.occluder_undetected;
    const PinholeCamera& c = options_.camera;
    const double d = options_.occluder_distance;
    object.size = {1.6 * c.width / c.fx * d, 1.6 * c.height / c.fy * d, 0.3};
    object.phase = rng.Uniform();
    objects_.push_back(object);
  }

  // Textures.
  const double tpm = options_.texels_per_metre;
  auto add_surface = [&](const OrientedBox& box, bool inside, double texels_per_metre,
                         TextureStyle style, uint64_t id) {
    Surface surface;
    surface.box = box;
    surface.inside = inside;
    surface.texels_per_metre = texels_per_metre;
    for (int face = 0; face < 6; ++face) {
      const int a = face / 2, b = (a + 1) % 3, c = (a + 2) % 3;
      surface.texture[face] =
          MakeProceduralTexture(2 * box.half_extents[b], 2 * box.half_extents[c], texels_per_metre,
                                MixSeed(options_.seed, id, static_cast<uint64_t>(face)), style);
    }
    surfaces_.push_back(std::move(surface));
  };
  add_surface(room_, true, tpm, TextureStyle::kRoom, 1000);
  for (size_t i = 0; i < static_boxes_.size(); ++i) {
    const bool pillar = options_.loop_inward && i + 1 == static_boxes_.size();
    add_surface(static_boxes_[i], false, pillar ? tpm : 1.2 * tpm,
                pillar ? TextureStyle::kRoom : TextureStyle::kFurniture, 2000 + i);
  }
  for (int i = 0; i < num_moving_objects(); ++i) {
    add_surface(MovingObjectBox(i, 0), false, 2.0 * tpm, TextureStyle::kClothing, 3000 + i);
  }
}

// ---------------------------------------------------------------------------------------------
// Time, camera path, object paths

Timestamp SyntheticScene::FrameStamp(int frame) const {
  const int64_t us = std::llround(frame * 1e6 / options_.sensor.fps);
  return Timestamp::FromNanoseconds(options_.start_stamp.nanoseconds() + us * 1000);
}

Timestamp SyntheticScene::DepthStamp(int frame) const {
  SynthRng rng(MixSeed(options_.seed, static_cast<uint64_t>(frame), 0x5A5Au));
  const double offset =
      options_.depth_stamp_offset + options_.depth_stamp_jitter * rng.Uniform(-1.0, 1.0);
  return Timestamp::FromNanoseconds(FrameStamp(frame).nanoseconds() +
                                    std::llround(offset * 1e6) * 1000);
}

double SyntheticScene::FrameTime(int frame) const {
  return SecondsBetween(FrameStamp(0), FrameStamp(frame));
}

Rigid3d SyntheticScene::WorldFromCamAtTime(double t) const {
  const SyntheticOptions& o = options_;
  const double w = 2 * kPi;
  if (o.loop_semi_axes.x() > 0) {
    // Rounded rectangle (half sizes a x b, corner radius r) walked anticlockwise at loop_speed from
    // (a, 0), looking along the outward normal: the walls stay at the same distance on the sides.
    const double a = o.loop_semi_axes.x(), b = o.loop_semi_axes.y();
    const double r = std::min({o.loop_corner_radius, a, b});
    const double perimeter = 4 * (a + b) - 8 * r + 2 * kPi * r;
    double d = std::fmod(t * o.loop_speed, perimeter);
    if (d < 0) d += perimeter;
    // Segments: straight (start point, direction, length) or arc (centre, start angle).
    Eigen::Vector2d xy(a, 0.0), normal(1.0, 0.0);
    const double straight_x = 2 * (a - r), straight_y = 2 * (b - r), arc = 0.5 * kPi * r;
    const Eigen::Vector2d centres[4] = {
        {a - r, b - r}, {-(a - r), b - r}, {-(a - r), -(b - r)}, {a - r, -(b - r)}};
    const double lengths[9] = {b - r, arc,        straight_x, arc,  straight_y,
                               arc,   straight_x, arc,        b - r};
    for (int seg = 0; seg < 9; ++seg) {
      const double step = std::min(d, lengths[seg]);
      if (seg % 2 == 0) {
        // Straight sides: 0 right (going +y), 1 top (-x), 2 left (-y), 3 bottom (+x), 4 right.
        const int side = seg / 2;
        const Eigen::Vector2d dirs[5] = {{0, 1}, {-1, 0}, {0, -1}, {1, 0}, {0, 1}};
        const Eigen::Vector2d normals[5] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}, {1, 0}};
        const Eigen::Vector2d starts[5] = {
            {a, 0}, {a - r, b}, {-a, b - r}, {-(a - r), -b}, {a, -(b - r)}};
        xy = starts[side] + step * dirs[side];
        normal = normals[side];
      } else {
        const int corner = seg / 2;
        const double phi = 0.5 * kPi * corner + step / r;
        normal = Eigen::Vector2d(std::cos(phi), std::sin(phi));
        xy = centres[corner] + r * normal;
      }
      if (d <= lengths[seg]) break;
      d -= lengths[seg];
    }
    const Eigen::Vector3d position(
        xy.x(), xy.y(), o.camera_height + 0.05 * std::sin(w * t / (0.8 * o.path_period) + 0.5));
    const double yaw =
        o.loop_inward ? std::atan2(-normal.y(), -normal.x()) : std::atan2(normal.y(), normal.x());
    const double pitch =
        (o.pitch_offset_deg + o.pitch_amplitude_deg * std::sin(w * t / o.pitch_period)) * kDeg;
    const double roll =
        o.roll_amplitude_deg * kDeg * std::sin(w * t / (1.3 * o.pitch_period) + 0.7);
    Eigen::Matrix3d look_x;
    look_x << 0, 0, 1, -1, 0, 0, 0, -1, 0;
    const Eigen::Matrix3d rotation =
        Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
        Eigen::AngleAxisd(-pitch, Eigen::Vector3d::UnitY()).toRotationMatrix() * look_x *
        Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    return Rigid3d(rotation, position);
  }
  const Eigen::Vector3d position(
      CameraBaseX(o) + o.path_amplitude * std::sin(w * t / o.path_period),
      0.8 * o.path_amplitude * std::sin(w * t / (1.37 * o.path_period) + 1.0),
      o.camera_height + 0.1 * std::sin(w * t / (0.8 * o.path_period) + 0.5));
  const double yaw = o.yaw_amplitude_deg * kDeg * std::sin(w * t / o.yaw_period);
  const double pitch =
      (o.pitch_offset_deg + o.pitch_amplitude_deg * std::sin(w * t / o.pitch_period)) * kDeg;
  const double roll = o.roll_amplitude_deg * kDeg * std::sin(w * t / (1.3 * o.pitch_period) + 0.7);
  // Camera looking along world +x: camera x -> world -y, camera y -> world -z, z -> world +x.
  Eigen::Matrix3d look_x;
  look_x << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
      Eigen::AngleAxisd(-pitch, Eigen::Vector3d::UnitY()).toRotationMatrix() * look_x *
      Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return Rigid3d(rotation, position);
}

int SyntheticScene::occluder_index() const {
  return options_.occluder_coverage > 0 ? num_moving_objects() - 1 : -1;
}

double SyntheticScene::OccluderCoverage(int frame) const {
  if (options_.occluder_coverage <= 0) return 0;
  const int ramp = options_.occluder_ramp_frames;
  const int start = options_.occluder_start_frame, full = start + ramp;
  const int leave = full + options_.occluder_frames, end = leave + ramp;
  double s = 0;  // 0..1 of the full coverage
  if (frame >= full && frame < leave) {
    s = 1;
  } else if (frame >= start && frame < full) {
    s = double(frame - start + 1) / (ramp + 1);
  } else if (frame >= leave && frame < end) {
    s = double(end - frame) / (ramp + 1);
  }
  return s * s * (3 - 2 * s) * options_.occluder_coverage;  // smoothstep in and out
}

bool SyntheticScene::IsObjectPresent(int object, int frame) const {
  if (object < 0 || object >= num_moving_objects()) return false;
  if (objects_[object].occluder) return OccluderCoverage(frame) > 0;
  return frame >= options_.objects_start_frame;
}

OrientedBox SyntheticScene::OccluderBox(const MovingObject& m, int frame) const {
  // In the camera frame: the left edge of the front face on image column (1 - coverage) * width,
  // the box reaching beyond the right border; the walker's sway moves it a few centimetres.
  const PinholeCamera& c = options_.camera;
  const double t = FrameTime(frame), w = 2 * kPi;
  const double sway_x = 0.02 * std::sin(w * (t / 1.1 + m.phase));
  const double sway_z = 0.02 * std::sin(w * (t / 0.9 + m.phase));
  const double d = options_.occluder_distance + sway_z;
  const double edge_u = (1 - OccluderCoverage(frame)) * c.width - 0.5;
  const double edge_x = (edge_u - c.cx) / c.fx * d + sway_x;
  const Eigen::Vector3d centre_cam(edge_x + m.size.x() / 2, 0.0, d + m.size.z() / 2);
  OrientedBox box;
  box.world_from_box = WorldFromCam(frame) * Rigid3d(Eigen::Quaterniond::Identity(), centre_cam);
  box.half_extents = m.size / 2;
  return box;
}

OrientedBox SyntheticScene::MovingObjectBox(int object, int frame) const {
  const MovingObject& m = objects_.at(object);
  if (m.occluder) return OccluderBox(m, frame);
  const double length = (m.lane_end - m.lane_start).norm();
  const double t = FrameTime(frame) - FrameTime(options_.objects_start_frame);
  double along = 0, yaw = 0;
  if (options_.object_pause <= 0) {
    double s = std::fmod(m.phase * 2 * length + m.speed * t, 2 * length);
    if (s < 0) s += 2 * length;
    along = length - std::abs(s - length);  // triangle wave in [0, length]
  } else {
    // Walk (length / speed), stand then turn (pause), walk back, stand then turn.
    const double walk = length / m.speed, pause = options_.object_pause;
    const double cycle = 2 * (walk + pause);
    double c = std::fmod(m.phase * cycle + t, cycle);
    if (c < 0) c += cycle;
    const int half = c < walk + pause ? 0 : 1;
    const double h = c - half * (walk + pause);
    const double walked = std::min(h, walk) / walk;
    along = half == 0 ? length * walked : length * (1 - walked);
    double turned = 0;  // 0..1 within this half cycle's turn
    if (options_.object_turn && h > walk + pause / 2) {
      const double x = (h - walk - pause / 2) / (pause / 2);
      turned = x * x * (3 - 2 * x);  // smoothstep
    }
    yaw = kPi * (half + turned);
  }
  OrientedBox box;
  box.world_from_box = Rigid3d(yaw == 0 ? Eigen::Quaterniond::Identity() : Yaw(yaw),
                               m.lane_start + (m.lane_end - m.lane_start) * (along / length));
  box.half_extents = m.size / 2;
  return box;
}

bool SyntheticScene::IsInsideMovingObject(const Eigen::Vector3d& p_world, int frame,
                                          double margin) const {
  for (int k = 0; k < num_moving_objects(); ++k) {
    if (IsObjectPresent(k, frame) && MovingObjectBox(k, frame).Contains(p_world, margin)) {
      return true;
    }
  }
  return false;
}

bool SyntheticScene::IsInSweptVolume(const Eigen::Vector3d& p_world, double margin) const {
  const int first = options_.occluder_coverage > 0
                        ? std::min(options_.objects_start_frame, options_.occluder_start_frame)
                        : options_.objects_start_frame;
  for (int frame = first; frame < options_.num_frames; ++frame) {
    if (IsInsideMovingObject(p_world, frame, margin)) return true;
  }
  return false;
}

double SyntheticScene::DistanceToStaticSurface(const Eigen::Vector3d& p_world) const {
  double best = room_.DistanceToSurface(p_world);
  for (const OrientedBox& box : static_boxes_)
    best = std::min(best, box.DistanceToSurface(p_world));
  return best;
}

// ---------------------------------------------------------------------------------------------
// Ray casting

// One surface as seen from one camera pose: rays in camera coordinates (x, y, 1) map to box
// coordinates as origin + direction_from_cam * (x, y, 1); the ray parameter is the depth z.
struct SurfaceView {
  int surface = 0;
  SyntheticHit::Kind kind = SyntheticHit::Kind::kRoom;
  int index = 0;
  bool inside = false;
  Eigen::Matrix3d box_from_cam = Eigen::Matrix3d::Identity();
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // camera centre in box coordinates
  Eigen::Vector3d half = Eigen::Vector3d::Zero();
  int u0 = 0, u1 = -1, v0 = 0, v1 = -1;  // conservative pixel rectangle (inclusive)
  float shade[6] = {1, 1, 1, 1, 1, 1};
};

struct SyntheticScene::FrameGeometry {
  Rigid3d world_from_cam;
  std::vector<SurfaceView> views;  // views[0] is the room
};

namespace {

struct LocalHit {
  double t = kInf;
  int view = -1;
  int face = 0;
  Eigen::Vector3d local = Eigen::Vector3d::Zero();
};

// Intersects the camera ray (x, y, 1) with one surface; updates `best` if nearer.
inline void IntersectView(const SurfaceView& view, int view_index, double x, double y,
                          LocalHit& best) {
  const Eigen::Vector3d d =
      view.box_from_cam.col(0) * x + view.box_from_cam.col(1) * y + view.box_from_cam.col(2);
  const Eigen::Vector3d& o = view.origin;
  const Eigen::Vector3d& h = view.half;
  if (view.inside) {  // leaving the box from inside: nearest exit plane
    double t_exit = kInf;
    int face = 0;
    for (int a = 0; a < 3; ++a) {
      if (d[a] == 0) continue;
      const double t = ((d[a] > 0 ? h[a] : -h[a]) - o[a]) / d[a];
      if (t < t_exit) {
        t_exit = t;
        face = 2 * a + (d[a] > 0 ? 1 : 0);
      }
    }
    if (t_exit > 0 && t_exit < best.t) {
      best.t = t_exit;
      best.view = view_index;
      best.face = face;
      best.local = o + t_exit * d;
    }
    return;
  }
  double t_near = -kInf, t_far = kInf;
  int face = 0;
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0) {
      if (std::abs(o[a]) > h[a]) return;
      continue;
    }
    const double inv = 1.0 / d[a];
    double t1 = (-h[a] - o[a]) * inv, t2 = (h[a] - o[a]) * inv;
    int entering = 2 * a;  // ray entering through the negative face when d > 0
    if (t1 > t2) {
      std::swap(t1, t2);
      entering = 2 * a + 1;
    }
    if (t1 > t_near) {
      t_near = t1;
      face = entering;
    }
    t_far = std::min(t_far, t2);
    if (t_near > t_far) return;
  }
  if (t_near > 1e-9 && t_near < best.t) {
    best.t = t_near;
    best.view = view_index;
    best.face = face;
    best.local = o + t_near * d;
  }
}

// Bilinear texture lookup at surface coordinates (metres) of a face.
inline void SampleTexture(const cv::Mat& texture, double u_m, double v_m, double texels_per_metre,
                          float* bgr) {
  const double x = std::clamp(u_m * texels_per_metre, 0.0, texture.cols - 1.001);
  const double y = std::clamp(v_m * texels_per_metre, 0.0, texture.rows - 1.001);
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  const uint8_t* r0 = texture.ptr<uint8_t>(y0) + 3 * x0;
  const uint8_t* r1 = texture.ptr<uint8_t>(y0 + 1) + 3 * x0;
  for (int c = 0; c < 3; ++c) {
    const float top = r0[c] + fx * (r0[3 + c] - r0[c]);
    const float bottom = r1[c] + fx * (r1[3 + c] - r1[c]);
    bgr[c] = top + fy * (bottom - top);
  }
}

}  // namespace

SyntheticScene::FrameGeometry SyntheticScene::PrepareFrame(int frame) const {
  FrameGeometry geometry;
  geometry.world_from_cam = WorldFromCam(frame);
  const Rigid3d cam_from_world = geometry.world_from_cam.Inverse();
  const PinholeCamera& camera = options_.camera;
  const Eigen::Vector3d light = Eigen::Vector3d(0.35, 0.25, 1.0).normalized();

  auto add_view = [&](int surface, SyntheticHit::Kind kind, int index, const OrientedBox& box) {
    SurfaceView view;
    view.surface = surface;
    view.kind = kind;
    view.index = index;
    view.inside = surfaces_[surface].inside;
    const Rigid3d box_from_cam = box.world_from_box.Inverse() * geometry.world_from_cam;
    view.box_from_cam = box_from_cam.RotationMatrix();
    view.origin = box_from_cam.translation;
    view.half = box.half_extents;
    view.u0 = 0;
    view.v0 = 0;
    view.u1 = camera.width - 1;
    view.v1 = camera.height - 1;
    if (!view.inside) {  // conservative image rectangle from the projected corners
      const Rigid3d cam_from_box = cam_from_world * box.world_from_box;
      double umin = kInf, umax = -kInf, vmin = kInf, vmax = -kInf;
      bool behind = false;
      for (int c = 0; c < 8; ++c) {
        const Eigen::Vector3d corner((c & 1 ? 1 : -1) * view.half.x(),
                                     (c & 2 ? 1 : -1) * view.half.y(),
                                     (c & 4 ? 1 : -1) * view.half.z());
        const Eigen::Vector3d p = cam_from_box * corner;
        if (p.z() < 1e-3) {
          behind = true;
          break;
        }
        const Eigen::Vector2d uv = camera.Project(p);
        umin = std::min(umin, uv.x());
        umax = std::max(umax, uv.x());
        vmin = std::min(vmin, uv.y());
        vmax = std::max(vmax, uv.y());
      }
      if (!behind) {
        // A ray through any point of a pixel (offsets within +-0.5) must be tested.
        view.u0 = static_cast<int>(std::max(0.0, std::floor(umin) - 1));
        view.u1 = static_cast<int>(std::min<double>(camera.width - 1, std::ceil(umax) + 1));
        view.v0 = static_cast<int>(std::max(0.0, std::floor(vmin) - 1));
        view.v1 = static_cast<int>(std::min<double>(camera.height - 1, std::ceil(vmax) + 1));
        if (view.u0 > view.u1 || view.v0 > view.v1) return;  // entirely outside the image
      }
    }
    const Eigen::Matrix3d world_from_box = box.world_from_box.RotationMatrix();
    for (int face = 0; face < 6; ++face) {
      Eigen::Vector3d normal = Eigen::Vector3d::Zero();
      normal[face / 2] = (face % 2 ? 1.0 : -1.0) * (view.inside ? -1.0 : 1.0);
      const double lambert = std::max(0.0, (world_from_box * normal).dot(light));
      view.shade[face] = static_cast<float>(0.6 + 0.4 * lambert);
    }
    geometry.views.push_back(view);
  };

  add_view(0, SyntheticHit::Kind::kRoom, 0, room_);
  for (size_t i = 0; i < static_boxes_.size(); ++i) {
    add_view(1 + static_cast<int>(i), SyntheticHit::Kind::kStaticBox, static_cast<int>(i),
             static_boxes_[i]);
  }
  for (int k = 0; k < num_moving_objects(); ++k) {
    if (!IsObjectPresent(k, frame)) continue;
    add_view(1 + static_cast<int>(static_boxes_.size()) + k, SyntheticHit::Kind::kMovingObject, k,
             MovingObjectBox(k, frame));
  }
  return geometry;
}

SyntheticHit SyntheticScene::CastPixel(int frame, double u, double v) const {
  const FrameGeometry geometry = PrepareFrame(frame);
  const PinholeCamera& camera = options_.camera;
  const double x = (u - camera.cx) / camera.fx, y = (v - camera.cy) / camera.fy;
  LocalHit best;
  for (size_t i = 0; i < geometry.views.size(); ++i) {
    IntersectView(geometry.views[i], static_cast<int>(i), x, y, best);  // no culling here
  }
  SyntheticHit hit;
  if (best.view < 0) return hit;  // cannot happen inside the closed room
  const SurfaceView& view = geometry.views[best.view];
  hit.kind = view.kind;
  hit.index = view.index;
  hit.face = best.face;
  hit.depth = best.t;
  hit.point_world = geometry.world_from_cam * Eigen::Vector3d(x * best.t, y * best.t, best.t);
  return hit;
}

SyntheticFrame SyntheticScene::RenderFrame(int frame) const {
  DYGSLAM_CHECK_OPTION(frame >= 0 && frame < options_.num_frames, "frame index");
  const FrameGeometry geometry = PrepareFrame(frame);
  const PinholeCamera& camera = options_.camera;
  const int width = camera.width, height = camera.height;
  const int n = options_.supersampling;
  const double factor = options_.sensor.depth_map_factor;

  SyntheticFrame out;
  out.index = frame;
  out.stamp = FrameStamp(frame);
  out.depth_stamp = DepthStamp(frame);
  out.world_from_cam = geometry.world_from_cam;
  out.rgb.create(height, width, CV_8UC3);
  out.depth.create(height, width, CV_16UC1);
  out.object_labels.create(height, width, CV_8UC1);

  SynthRng depth_rng(MixSeed(options_.seed, static_cast<uint64_t>(frame), 0xDE9Du));
  SynthRng rgb_rng(MixSeed(options_.seed, static_cast<uint64_t>(frame), 0xC010u));
  std::vector<int> row_views;
  row_views.reserve(geometry.views.size());
  const int num_objects = num_moving_objects();
  std::vector<int> min_u(num_objects, width), max_u(num_objects, -1);
  std::vector<int> min_v(num_objects, height), max_v(num_objects, -1), count(num_objects, 0);

  auto cast = [&](double x, double y, int u) {
    LocalHit best;
    for (int i : row_views) {
      const SurfaceView& view = geometry.views[i];
      if (u < view.u0 || u > view.u1) continue;
      IntersectView(view, i, x, y, best);
    }
    return best;
  };
  auto shade = [&](const LocalHit& hit, float* bgr) {
    const SurfaceView& view = geometry.views[hit.view];
    const Surface& surface = surfaces_[view.surface];
    const int a = hit.face / 2, b = (a + 1) % 3, c = (a + 2) % 3;
    SampleTexture(surface.texture[hit.face], hit.local[b] + view.half[b],
                  hit.local[c] + view.half[c], surface.texels_per_metre, bgr);
    for (int k = 0; k < 3; ++k) bgr[k] *= view.shade[hit.face];
  };

  // Pass 1: pixel-centre rays give depth, labels and the surface (view, face) of each pixel.
  std::vector<LocalHit> centres(static_cast<size_t>(width) * height);
  for (int v = 0; v < height; ++v) {
    row_views.clear();
    for (size_t i = 0; i < geometry.views.size(); ++i) {
      if (v >= geometry.views[i].v0 && v <= geometry.views[i].v1) {
        row_views.push_back(static_cast<int>(i));
      }
    }
    uint16_t* depth_row = out.depth.ptr<uint16_t>(v);
    uint8_t* label_row = out.object_labels.ptr<uint8_t>(v);
    const double y_centre = (v - camera.cy) / camera.fy;
    for (int u = 0; u < width; ++u) {
      const double x_centre = (u - camera.cx) / camera.fx;
      const LocalHit& centre = centres[static_cast<size_t>(v) * width + u] =
          cast(x_centre, y_centre, u);
      const SurfaceView& centre_view = geometry.views[centre.view];
      uint8_t label = 0;
      if (centre_view.kind == SyntheticHit::Kind::kMovingObject) {
        const int k = centre_view.index;
        label = static_cast<uint8_t>(k + 1);
        min_u[k] = std::min(min_u[k], u);
        max_u[k] = std::max(max_u[k], u);
        min_v[k] = std::min(min_v[k], v);
        max_v[k] = std::max(max_v[k], v);
        ++count[k];
      }
      label_row[u] = label;
      double z = centre.t;
      if (options_.depth_noise) {
        z += options_.depth_noise_coefficient * z * z * depth_rng.Normal();
      }
      const double raw = std::round(z * factor);
      const bool valid = z > 0 && raw >= 1 && raw <= 65535 &&
                         (options_.min_depth <= 0 || z >= options_.min_depth) &&
                         (options_.max_depth <= 0 || z <= options_.max_depth);
      depth_row[u] = valid ? static_cast<uint16_t>(raw) : 0;
    }
  }

  // Pass 2: colour, the mean of n x n sub-pixel samples. Inside the image of one face (the
  // pixel and its 8 neighbours see the same face) every sub-pixel ray hits that face too (the
  // projection of a convex face is convex), so only that plane is intersected; elsewhere the
  // sub-pixel rays are cast against the whole scene.
  auto same_surface = [&](const LocalHit& a, int u, int v) {
    if (u < 0 || v < 0 || u >= width || v >= height) return false;
    const LocalHit& b = centres[static_cast<size_t>(v) * width + u];
    return a.view == b.view && a.face == b.face;
  };
  for (int v = 0; v < height; ++v) {
    row_views.clear();
    for (size_t i = 0; i < geometry.views.size(); ++i) {
      if (v >= geometry.views[i].v0 && v <= geometry.views[i].v1) {
        row_views.push_back(static_cast<int>(i));
      }
    }
    uint8_t* rgb_row = out.rgb.ptr<uint8_t>(v);
    for (int u = 0; u < width; ++u) {
      const LocalHit& centre = centres[static_cast<size_t>(v) * width + u];
      float sum[3] = {0, 0, 0};
      float bgr[3];
      if (n == 1) {
        shade(centre, sum);
      } else {
        bool interior = true;
        for (int dv = -1; dv <= 1 && interior; ++dv) {
          for (int du = -1; du <= 1 && interior; ++du) {
            interior = same_surface(centre, u + du, v + dv);
          }
        }
        const SurfaceView& view = geometry.views[centre.view];
        const int axis = centre.face / 2;
        const double plane = (centre.face % 2 ? 1.0 : -1.0) * view.half[axis];
        for (int j = 0; j < n; ++j) {
          const double y = (v + (j + 0.5) / n - 0.5 - camera.cy) / camera.fy;
          for (int i = 0; i < n; ++i) {
            const double x = (u + (i + 0.5) / n - 0.5 - camera.cx) / camera.fx;
            if (interior) {
              LocalHit hit = centre;
              const Eigen::Vector3d d = view.box_from_cam.col(0) * x +
                                        view.box_from_cam.col(1) * y + view.box_from_cam.col(2);
              hit.t = (plane - view.origin[axis]) / d[axis];
              hit.local = view.origin + hit.t * d;
              shade(hit, bgr);
            } else {
              shade(cast(x, y, u), bgr);
            }
            for (int k = 0; k < 3; ++k) sum[k] += bgr[k];
          }
        }
        for (float& s : sum) s /= static_cast<float>(n * n);
      }
      for (int k = 0; k < 3; ++k) {
        double value = sum[k];
        if (options_.rgb_noise_sigma > 0) value += options_.rgb_noise_sigma * rgb_rng.Normal();
        rgb_row[3 * u + k] = static_cast<uint8_t>(std::clamp(std::floor(value + 0.5), 0.0, 255.0));
      }
    }
  }

  out.dynamic_mask = out.object_labels > 0;  // 255 / 0
  for (int k = 0; k < num_objects; ++k) {
    if (count[k] < options_.min_detection_pixels || !objects_[k].detected) continue;
    Detection detection;
    detection.box = cv::Rect2f(static_cast<float>(min_u[k]), static_cast<float>(min_v[k]),
                               static_cast<float>(max_u[k] - min_u[k] + 1),
                               static_cast<float>(max_v[k] - min_v[k] + 1));
    detection.class_id = 0;
    detection.label = "person";
    detection.score = 1.0f;
    out.boxes.push_back(detection);
    out.box_object_ids.push_back(k);
  }
  return out;
}

}  // namespace dygslam
