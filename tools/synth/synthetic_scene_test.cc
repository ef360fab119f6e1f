#include "tools/synth/synthetic_scene.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "core/base/error.h"

namespace dygslam {
namespace {

// Half-resolution camera (same field of view) to keep the tests fast.
SyntheticOptions SmallOptions(int objects = 2, uint64_t seed = 7) {
  SyntheticOptions options;
  options.camera.width = 320;
  options.camera.height = 240;
  options.camera.fx = options.camera.fy = 262.5;
  options.camera.cx = 159.5;
  options.camera.cy = 119.5;
  options.num_frames = 60;
  options.num_moving_objects = objects;
  options.seed = seed;
  return options;
}

bool SameMat(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

double Metres(const cv::Mat& depth, int u, int v, double factor = 5000.0) {
  return depth.at<uint16_t>(v, u) / factor;
}

TEST(SyntheticScene, SameSeedGivesIdenticalFramesOtherSeedDiffers) {
  const SyntheticScene a(SmallOptions(2, 11)), b(SmallOptions(2, 11)), c(SmallOptions(2, 12));
  for (int frame : {0, 17}) {
    const SyntheticFrame fa = a.RenderFrame(frame), fb = b.RenderFrame(frame);
    EXPECT_TRUE(SameMat(fa.rgb, fb.rgb));
    EXPECT_TRUE(SameMat(fa.depth, fb.depth));
    EXPECT_TRUE(SameMat(fa.dynamic_mask, fb.dynamic_mask));
    ASSERT_EQ(fa.boxes.size(), fb.boxes.size());
    for (size_t i = 0; i < fa.boxes.size(); ++i) EXPECT_EQ(fa.boxes[i].box, fb.boxes[i].box);
  }
  // Rendering order does not matter: frame 17 rendered first in another scene is the same.
  const SyntheticScene d(SmallOptions(2, 11));
  EXPECT_TRUE(SameMat(d.RenderFrame(17).rgb, a.RenderFrame(17).rgb));
  // Another seed changes the textures.
  const cv::Mat diff = a.RenderFrame(0).rgb != c.RenderFrame(0).rgb;
  EXPECT_GT(cv::countNonZero(diff.reshape(1)), 0.5 * diff.total() * 3);
}

TEST(SyntheticScene, NoiseIsDeterministicToo) {
  SyntheticOptions options = SmallOptions(1, 3);
  options.depth_noise = true;
  options.rgb_noise_sigma = 2.0;
  const SyntheticScene a(options), b(options);
  const SyntheticFrame fa = a.RenderFrame(4), fb = b.RenderFrame(4);
  EXPECT_TRUE(SameMat(fa.rgb, fb.rgb));
  EXPECT_TRUE(SameMat(fa.depth, fb.depth));
}

TEST(SyntheticScene, DepthOfKnownWallMatchesAnalyticValue) {
  const SyntheticOptions options = SmallOptions(0);
  const SyntheticScene scene(options);
  const double hx = options.room_size.x() / 2;
  const PinholeCamera& camera = options.camera;
  int checked = 0;
  for (int frame : {0, 10, 30, 45}) {
    const SyntheticFrame f = scene.RenderFrame(frame);
    const Eigen::Matrix3d r = f.world_from_cam.RotationMatrix();
    const Eigen::Vector3d c = f.world_from_cam.translation;
    for (int v = 5; v < camera.height; v += 23) {
      for (int u = 3; u < camera.width; u += 29) {
        // Analytic: the ray hits the front wall x = hx at t with depth z = t (ray (x, y, 1)).
        const Eigen::Vector3d d =
            r * Eigen::Vector3d((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0);
        if (d.x() <= 0) continue;
        const double z = (hx - c.x()) / d.x();
        const Eigen::Vector3d p = c + z * d;
        // Only where the wall is visible: inside the wall and nothing else nearer.
        if (std::abs(p.y()) > options.room_size.y() / 2 || p.z() < 0 ||
            p.z() > options.room_size.z()) {
          continue;
        }
        const SyntheticHit hit = scene.CastPixel(frame, u, v);
        if (hit.kind != SyntheticHit::Kind::kRoom || hit.face != 1) continue;
        EXPECT_NEAR(Metres(f.depth, u, v), z, 0.5 / 5000 + 1e-9) << "frame " << frame;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 50);
}

TEST(SyntheticScene, BackProjectedPixelsLieOnRenderedSurfaces) {
  const SyntheticOptions options = SmallOptions(2);
  const SyntheticScene scene(options);
  int on_static = 0, on_object = 0;
  for (int frame : {3, 29, 52}) {
    const SyntheticFrame f = scene.RenderFrame(frame);
    for (int v = 0; v < options.camera.height; v += 7) {
      for (int u = 0; u < options.camera.width; u += 7) {
        const double z = Metres(f.depth, u, v);
        ASSERT_GT(z, 0.3);
        const Eigen::Vector3d p =
            f.world_from_cam * options.camera.Unproject(u, v, z);  // ground-truth pose
        if (f.object_labels.at<uint8_t>(v, u) == 0) {
          EXPECT_LT(scene.DistanceToStaticSurface(p), 1e-3) << u << "," << v;
          EXPECT_FALSE(scene.IsInsideMovingObject(p, frame, -1e-3));
          ++on_static;
        } else {
          const int k = f.object_labels.at<uint8_t>(v, u) - 1;
          const OrientedBox box = scene.MovingObjectBox(k, frame);
          EXPECT_LT(box.DistanceToSurface(p), 1e-3);
          EXPECT_TRUE(scene.IsInsideMovingObject(p, frame, 1e-3));
          EXPECT_TRUE(scene.IsInSweptVolume(p, 1e-3));
          ++on_object;
        }
      }
    }
  }
  EXPECT_GT(on_static, 1000);
  EXPECT_GT(on_object, 20);
}

TEST(SyntheticScene, MaskAgreesWithBoxesAndDepth) {
  const SyntheticOptions options = SmallOptions(3, 5);
  const SyntheticScene scene(options);
  SyntheticOptions static_options = options;
  static_options.num_moving_objects = 0;
  const SyntheticScene static_scene(static_options);  // same room, textures and camera path
  double max_fraction = 0;
  int frames_with_objects = 0;
  for (int frame = 0; frame < options.num_frames; frame += 6) {
    const SyntheticFrame f = scene.RenderFrame(frame);
    const SyntheticFrame s = static_scene.RenderFrame(frame);
    ASSERT_EQ(f.boxes.size(), f.box_object_ids.size());
    EXPECT_TRUE(SameMat(f.dynamic_mask, (f.object_labels > 0)));
    cv::Mat covered = cv::Mat::zeros(f.dynamic_mask.size(), CV_8U);
    for (size_t i = 0; i < f.boxes.size(); ++i) {
      const Detection& d = f.boxes[i];
      EXPECT_EQ(d.class_id, 0);
      EXPECT_EQ(d.label, "person");
      const cv::Rect rect(cv::Point(cvRound(d.box.x), cvRound(d.box.y)),
                          cv::Size(cvRound(d.box.width), cvRound(d.box.height)));
      const cv::Mat object = f.object_labels == f.box_object_ids[i] + 1;
      // Tight: every pixel of the object lies in the box and every box edge touches the object.
      EXPECT_EQ(cv::countNonZero(object(rect)), cv::countNonZero(object));
      EXPECT_GT(cv::countNonZero(object(rect).row(0)), 0);
      EXPECT_GT(cv::countNonZero(object(rect).row(rect.height - 1)), 0);
      EXPECT_GT(cv::countNonZero(object(rect).col(0)), 0);
      EXPECT_GT(cv::countNonZero(object(rect).col(rect.width - 1)), 0);
      covered(rect).setTo(255);
    }
    // Every masked pixel belongs to some box (objects below min_detection_pixels excepted).
    const int masked = cv::countNonZero(f.dynamic_mask);
    const cv::Mat outside = f.dynamic_mask & ~covered;
    EXPECT_LE(cv::countNonZero(outside), options.min_detection_pixels * options.num_moving_objects);
    // Depth: objects are in front of the static scene; elsewhere the images equal the static ones.
    int in_front = 0;
    for (int v = 0; v < f.depth.rows; ++v) {
      for (int u = 0; u < f.depth.cols; ++u) {
        if (f.dynamic_mask.at<uint8_t>(v, u)) {
          // Objects stand on the floor: only where they touch it may the depths be equal.
          ASSERT_LE(f.depth.at<uint16_t>(v, u), s.depth.at<uint16_t>(v, u));
          in_front += f.depth.at<uint16_t>(v, u) + 5 < s.depth.at<uint16_t>(v, u);
        } else {
          ASSERT_EQ(f.depth.at<uint16_t>(v, u), s.depth.at<uint16_t>(v, u));
        }
      }
    }
    EXPECT_GE(in_front, 0.99 * masked);
    cv::Mat rgb_diff;
    cv::absdiff(f.rgb, s.rgb, rgb_diff);
    cv::Mat changed;
    cv::cvtColor(rgb_diff, changed, cv::COLOR_BGR2GRAY);
    changed = changed > 0;
    cv::Mat grown;  // colour may differ one pixel around the mask (sub-pixel samples)
    cv::dilate(f.dynamic_mask, grown, cv::Mat::ones(3, 3, CV_8U));
    EXPECT_EQ(cv::countNonZero(changed & ~grown), 0);
    max_fraction = std::max(max_fraction, masked / static_cast<double>(f.dynamic_mask.total()));
    frames_with_objects += !f.boxes.empty();
  }
  EXPECT_GT(max_fraction, 0.15);  // people cover a sizeable part of the image at times
  EXPECT_GE(frames_with_objects, 5);
}

TEST(SyntheticScene, StaticPointLooksTheSameFromTwoViews) {
  const SyntheticOptions options = SmallOptions(0);
  const SyntheticScene scene(options);
  const PinholeCamera& camera = options.camera;
  const SyntheticFrame f0 = scene.RenderFrame(0), f1 = scene.RenderFrame(20);
  const Rigid3d cam1_from_world = f1.world_from_cam.Inverse();
  std::vector<double> diffs, shuffled_diffs;
  for (int v = 10; v < camera.height - 10; v += 9) {
    for (int u = 10; u < camera.width - 10; u += 9) {
      const Eigen::Vector3d p = f0.world_from_cam * camera.Unproject(u, v, Metres(f0.depth, u, v));
      const Eigen::Vector3d q = cam1_from_world * p;
      if (q.z() < 0.3) continue;
      const Eigen::Vector2d uv = camera.Project(q);
      if (uv.x() < 2 || uv.y() < 2 || uv.x() > camera.width - 3 || uv.y() > camera.height - 3) {
        continue;
      }
      const SyntheticHit hit = scene.CastPixel(20, uv.x(), uv.y());
      if ((hit.point_world - p).norm() > 0.01) continue;  // occluded in frame 20
      cv::Mat patch0, patch1;
      cv::getRectSubPix(f0.rgb, cv::Size(1, 1), cv::Point2f(u, v), patch0, CV_32F);
      cv::getRectSubPix(f1.rgb, cv::Size(1, 1), cv::Point2f(uv.x(), uv.y()), patch1, CV_32F);
      diffs.push_back(cv::norm(patch0, patch1, cv::NORM_L1) / 3);
      cv::getRectSubPix(f1.rgb, cv::Size(1, 1), cv::Point2f(camera.width - 1 - uv.x(), uv.y()),
                        patch1, CV_32F);
      shuffled_diffs.push_back(cv::norm(patch0, patch1, cv::NORM_L1) / 3);
    }
  }
  ASSERT_GT(diffs.size(), 300u);
  auto median = [](std::vector<double> x) {
    std::nth_element(x.begin(), x.begin() + x.size() / 2, x.end());
    return x[x.size() / 2];
  };
  EXPECT_LT(median(diffs), 6.0);
  EXPECT_GT(median(shuffled_diffs), 4 * median(diffs) + 5);  // the test can tell
}

TEST(SyntheticScene, FastCornersArePlentifulAndSpread) {
  SyntheticOptions options;  // full 640x480
  options.num_moving_objects = 2;
  const SyntheticScene scene(options);
  for (int frame : {0, 33, 66, 99}) {
    const SyntheticFrame f = scene.RenderFrame(frame);
    cv::Mat gray;
    cv::cvtColor(f.rgb, gray, cv::COLOR_BGR2GRAY);
    std::vector<cv::KeyPoint> corners;
    cv::FAST(gray, corners, 20, true);
    EXPECT_GE(corners.size(), 500u) << "frame " << frame;
    int cells[6][8] = {};
    for (const cv::KeyPoint& k : corners) {
      ++cells[std::min(5, static_cast<int>(k.pt.y * 6 / gray.rows))]
             [std::min(7, static_cast<int>(k.pt.x * 8 / gray.cols))];
    }
    int occupied = 0;
    for (auto& row : cells) {
      for (int count : row) occupied += count >= 3;
    }
    EXPECT_GE(occupied, 0.7 * 48) << "frame " << frame;
  }
}

TEST(SyntheticScene, CameraPathIsHandheldAndInsideTheRoom) {
  SyntheticOptions options = SmallOptions(2);
  options.num_frames = 300;
  const SyntheticScene scene(options);
  const double dt = 1.0 / options.sensor.fps;
  double max_speed = 0, max_rate = 0;
  std::vector<double> centre_depths;
  for (int i = 0; i + 1 < options.num_frames; ++i) {
    const Rigid3d a = scene.WorldFromCam(i), b = scene.WorldFromCam(i + 1);
    max_speed = std::max(max_speed, (b.translation - a.translation).norm() / dt);
    max_rate = std::max(max_rate, RotationAngle(a.rotation.conjugate() * b.rotation) / dt);
    EXPECT_TRUE(scene.room().Contains(a.translation, -0.5));
    EXPECT_FALSE(scene.IsInsideMovingObject(a.translation, i, 0.3));
    for (const OrientedBox& box : scene.static_boxes())
      EXPECT_FALSE(box.Contains(a.translation, 0.3));
    if (i % 10 == 0) centre_depths.push_back(scene.CastPixel(i, 159.5, 119.5).depth);
  }
  EXPECT_GT(max_speed, 0.15);
  EXPECT_LT(max_speed, 0.6);
  EXPECT_GT(max_rate * 180 / M_PI, 10.0);
  EXPECT_LT(max_rate * 180 / M_PI, 40.0);
  for (double z : centre_depths) {
    EXPECT_GT(z, 0.5);
    EXPECT_LT(z, 5.0);  // the far corners of the room
  }
  std::nth_element(centre_depths.begin(), centre_depths.begin() + centre_depths.size() / 2,
                   centre_depths.end());
  const double median_depth = centre_depths[centre_depths.size() / 2];
  EXPECT_GT(median_depth, 1.0);
  EXPECT_LT(median_depth, 4.0);
  // Rotation is a proper camera: +z of the camera at yaw = pitch = 0 would be world +x.
  const Eigen::Vector3d forward = scene.WorldFromCam(0).RotationMatrix().col(2);
  EXPECT_GT(forward.x(), 0.9);
  EXPECT_LT(forward.z(), 0.0);  // looks slightly down
}

TEST(SyntheticScene, ObjectsWalkBackAndForthOnTheFloor) {
  SyntheticOptions options = SmallOptions(3);
  options.num_frames = 400;
  options.objects_start_frame = 30;
  const SyntheticScene scene(options);
  const double dt = 1.0 / options.sensor.fps;
  for (int k = 0; k < 3; ++k) {
    EXPECT_FALSE(scene.IsObjectPresent(k, 29));
    EXPECT_TRUE(scene.IsObjectPresent(k, 30));
    double min_y = 1e9, max_y = -1e9, max_speed = 0;
    for (int i = 30; i + 1 < options.num_frames; ++i) {
      const OrientedBox a = scene.MovingObjectBox(k, i), b = scene.MovingObjectBox(k, i + 1);
      EXPECT_NEAR(a.world_from_box.translation.z() - a.half_extents.z(), 0.0, 1e-9);  // on floor
      EXPECT_TRUE(scene.room().Contains(a.world_from_box.translation, -0.3));
      for (const OrientedBox& box : scene.static_boxes()) {
        EXPECT_GT(box.DistanceToSurface(a.world_from_box.translation), 0.3);
      }
      min_y = std::min(min_y, a.world_from_box.translation.y());
      max_y = std::max(max_y, a.world_from_box.translation.y());
      max_speed = std::max(
          max_speed, (b.world_from_box.translation - a.world_from_box.translation).norm() / dt);
    }
    EXPECT_GT(max_y - min_y, 2.5);  // crosses the room and turns back
    EXPECT_GT(max_speed, 0.75);
    EXPECT_LT(max_speed, 1.25);
  }
  // The camera position is neither in an object's swept volume nor on a static surface.
  const Eigen::Vector3d camera = scene.WorldFromCam(0).translation;
  EXPECT_FALSE(scene.IsInSweptVolume(camera, 0.2));
  EXPECT_FALSE(scene.IsStaticSurface(camera, 0.5));
  const OrientedBox first = scene.MovingObjectBox(0, 100);
  EXPECT_TRUE(scene.IsInSweptVolume(first.world_from_box.translation));
  EXPECT_TRUE(scene.IsInsideMovingObject(first.world_from_box.translation, 100));
  EXPECT_FALSE(scene.IsInsideMovingObject(first.world_from_box.translation, 10));  // not yet there
  EXPECT_TRUE(scene.IsStaticSurface(Eigen::Vector3d(0.3, 0.2, 0.0), 1e-9));        // floor
}

TEST(SyntheticScene, DepthNoiseAndRangeLimits) {
  SyntheticOptions clean = SmallOptions(0);
  SyntheticOptions noisy = clean;
  noisy.depth_noise = true;
  noisy.depth_noise_coefficient = 0.004;
  SyntheticOptions limited = clean;
  limited.max_depth = 3.0;
  const SyntheticFrame c = SyntheticScene(clean).RenderFrame(8);
  const SyntheticFrame n = SyntheticScene(noisy).RenderFrame(8);
  const SyntheticFrame l = SyntheticScene(limited).RenderFrame(8);
  double sum_sq_normalised = 0;
  int count = 0, beyond = 0;
  for (int v = 0; v < c.depth.rows; ++v) {
    for (int u = 0; u < c.depth.cols; ++u) {
      const double z = Metres(c.depth, u, v);
      const double e = Metres(n.depth, u, v) - z;
      const double sigma = noisy.depth_noise_coefficient * z * z;
      sum_sq_normalised += e * e / (sigma * sigma);
      ++count;
      if (z > 3.0 + 1e-3) {
        EXPECT_EQ(l.depth.at<uint16_t>(v, u), 0);
        ++beyond;
      } else if (z < 3.0 - 1e-3) {
        EXPECT_EQ(l.depth.at<uint16_t>(v, u), c.depth.at<uint16_t>(v, u));
      }
    }
  }
  EXPECT_NEAR(std::sqrt(sum_sq_normalised / count), 1.0, 0.1);
  EXPECT_GT(beyond, 100);
}

// Inward loop: the camera looks at the central pillar from the corner radius on the
// whole lap, on the sides and while orbiting the pillar's edges at the corners.
TEST(SyntheticScene, InwardLoopKeepsThePillarAtTheCornerRadius) {
  SyntheticOptions options = SmallOptions(0);
  options.room_size = {8.5, 7.0, 3.0};
  options.loop_semi_axes = {3.0, 2.2};
  options.loop_corner_radius = 1.2;
  options.loop_inward = true;
  options.loop_speed = 1.4;
  options.sensor.fps = 20;
  options.texels_per_metre = 100;  // textures are not looked at here
  const double perimeter = 4 * (3.0 + 2.2) - 8 * 1.2 + 2 * M_PI * 1.2;
  options.num_frames = static_cast<int>(perimeter / 1.4 * 20) + 1;
  const SyntheticScene scene(options);
  const int pillar = static_cast<int>(scene.static_boxes().size()) - 1;
  EXPECT_NEAR(scene.static_boxes().back().half_extents.x(), 1.8, 1e-12);
  EXPECT_NEAR(scene.static_boxes().back().half_extents.y(), 1.0, 1e-12);
  double min_depth = 1e9, max_depth = 0;
  for (int i = 0; i < options.num_frames; i += 5) {
    const SyntheticHit hit = scene.CastPixel(i, options.camera.cx, options.camera.cy);
    ASSERT_EQ(hit.kind, SyntheticHit::Kind::kStaticBox) << "frame " << i;
    ASSERT_EQ(hit.index, pillar) << "frame " << i;
    min_depth = std::min(min_depth, hit.depth);
    max_depth = std::max(max_depth, hit.depth);
    // Camera on the path: 1.2 m from the pillar's surface, horizontally.
    const Eigen::Vector3d c = scene.WorldFromCam(i).translation;
    EXPECT_NEAR(scene.static_boxes().back().DistanceToSurface(c), 1.2, 1e-6) << "frame " << i;
  }
  // Optical axis pitched by at most 14 deg (and rolled): depth r .. r / cos(14 deg).
  EXPECT_GE(min_depth, 1.2 - 1e-6);
  EXPECT_LE(max_depth, 1.2 / std::cos(14.0 * M_PI / 180) + 1e-6);
  // After one lap the camera is back where it started (the height sways): the path is closed.
  EXPECT_LT(
      (scene.WorldFromCam(0).translation - scene.WorldFromCamAtTime(perimeter / 1.4).translation)
          .head<2>()
          .norm(),
      1e-9);
}

TEST(SyntheticScene, BadOptionsNameTheField) {
  auto message_of = [](const SyntheticOptions& options) {
    try {
      options.Check();
    } catch (const InvalidOptions& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  SyntheticOptions options;
  EXPECT_EQ(message_of(options), "");
  options.num_frames = 0;
  EXPECT_NE(message_of(options).find("num_frames"), std::string::npos);
  options = SyntheticOptions();
  options.num_moving_objects = 9;
  EXPECT_NE(message_of(options).find("num_moving_objects"), std::string::npos);
  options = SyntheticOptions();
  options.camera.k1 = 0.1;
  EXPECT_NE(message_of(options).find("distortion"), std::string::npos);
  options = SyntheticOptions();
  options.room_size.x() = 3;
  EXPECT_NE(message_of(options).find("room_size"), std::string::npos);
  options = SyntheticOptions();
  options.camera.fx = -1;
  EXPECT_NE(message_of(options).find("Camera.fx"), std::string::npos);
  EXPECT_THROW(SyntheticScene{options}, InvalidOptions);
  EXPECT_THROW(SyntheticScene(SmallOptions()).RenderFrame(60), InvalidOptions);
  options = SyntheticOptions();
  options.num_undetected_objects = 3;  // more than the 2 objects
  EXPECT_NE(message_of(options).find("num_undetected_objects"), std::string::npos);
  options = SyntheticOptions();
  options.near_object_distance = 0.3;  // inside the camera's path
  EXPECT_NE(message_of(options).find("near_object_distance"), std::string::npos);
  options = SyntheticOptions();
  options.object_pause = -1;
  EXPECT_NE(message_of(options).find("object_pause"), std::string::npos);
  options = SyntheticOptions();
  options.room_size = {9.0, 7.0, 3.0};
  options.loop_semi_axes = {2.5, 1.5};
  options.loop_corner_radius = 1.5;  // b - r = 0: no room for a pillar
  options.loop_inward = true;
  EXPECT_NE(message_of(options).find("loop_inward"), std::string::npos);
}

// The hard cases of real data: movers walk, stop, stand, turn round and walk back; one is never
// detected; one passes close enough to fill about half the view.
TEST(SyntheticScene, MoversStopTurnAndOneIsNeverDetected) {
  SyntheticOptions options = SmallOptions(2, 21);
  options.num_frames = 600;  // 20 s: several walks and pauses
  options.object_pause = 1.0;
  options.object_turn = true;
  options.num_undetected_objects = 1;
  const SyntheticScene scene(options);
  ASSERT_TRUE(scene.IsObjectDetected(0));
  ASSERT_FALSE(scene.IsObjectDetected(1));
  int walking = 0, standing = 0, turning = 0;
  double max_yaw_change = 0;
  for (int f = 1; f < options.num_frames; ++f) {
    const Rigid3d a = scene.MovingObjectBox(0, f - 1).world_from_box;
    const Rigid3d b = scene.MovingObjectBox(0, f).world_from_box;
    const double moved = (b.translation - a.translation).norm();
    const double turned = a.rotation.angularDistance(b.rotation);
    max_yaw_change = std::max(max_yaw_change, turned);
    walking += moved > 1e-6 && turned < 1e-9;
    standing += moved < 1e-9 && turned < 1e-9;
    turning += moved < 1e-9 && turned > 1e-9;
  }
  // Walking ~0.8-1.2 m/s on ~3 m lanes (~3 s) then 0.5 s standing, 0.5 s turning, per end.
  EXPECT_GT(walking, 300);
  EXPECT_GT(standing, 40);
  EXPECT_GT(turning, 40);
  // Smooth: a smoothstep over half the pause (15 frames) peaks at 1.5 pi / 15 = 0.31 rad/frame.
  EXPECT_LT(max_yaw_change, 0.33);
  EXPECT_GT(max_yaw_change, 0.25);
  // The undetected object shows up in the labels but never in the boxes.
  int frames_with_undetected = 0;
  for (int f = 0; f < options.num_frames; f += 50) {
    const SyntheticFrame frame = scene.RenderFrame(f);
    const int pixels = cv::countNonZero(frame.object_labels == 2);
    frames_with_undetected += pixels >= options.min_detection_pixels;
    for (int id : frame.box_object_ids) EXPECT_NE(id, 1);
  }
  EXPECT_GT(frames_with_undetected, 0);
}

TEST(SyntheticScene, NearMoverFillsAboutHalfTheView) {
  SyntheticOptions options = SmallOptions(1, 4);
  options.num_frames = 180;
  options.path_amplitude = 0.1;
  options.near_object_distance = 0.75;
  const SyntheticScene scene(options);
  ASSERT_EQ(scene.num_moving_objects(), 2);
  double max_share = 0;
  for (int f = 0; f < options.num_frames; f += 6) {
    const SyntheticFrame frame = scene.RenderFrame(f);
    max_share = std::max(max_share, cv::countNonZero(frame.object_labels == 2) /
                                        static_cast<double>(frame.object_labels.total()));
  }
  EXPECT_GT(max_share, 0.4);
}

// The crowd stretch: a person walking with the camera covers the asked share of the view for the
// asked frames (after sliding in), close in front of it, and is boxed unless undetected.
TEST(SyntheticScene, OccluderCoversItsShareOfTheViewForItsStretch) {
  for (const bool undetected : {false, true}) {
    SyntheticOptions options = SmallOptions(1, 5);
    options.num_frames = 40;
    options.occluder_coverage = 0.8;
    options.occluder_start_frame = 10;
    options.occluder_frames = 12;
    options.occluder_ramp_frames = 4;
    options.occluder_undetected = undetected;
    const SyntheticScene scene(options);
    ASSERT_EQ(scene.num_moving_objects(), 2);
    const int occluder = scene.occluder_index();
    ASSERT_EQ(occluder, 1);
    EXPECT_EQ(scene.IsObjectDetected(occluder), !undetected);
    for (int f = 0; f < options.num_frames; f += 3) {
      const SyntheticFrame frame = scene.RenderFrame(f);
      const cv::Mat on_occluder = frame.object_labels == occluder + 1;
      const double share = cv::countNonZero(on_occluder) / double(on_occluder.total());
      const bool boxed =
          std::count(frame.box_object_ids.begin(), frame.box_object_ids.end(), occluder) > 0;
      SCOPED_TRACE("frame " + std::to_string(f));
      if (f < 10 || f >= 10 + 4 + 12 + 4) {  // before it slides in, after it has left
        EXPECT_EQ(share, 0);
        EXPECT_FALSE(scene.IsObjectPresent(occluder, f));
      } else if (f >= 14 && f < 26) {  // the full stretch: the share, give or take the sway
        EXPECT_NEAR(share, 0.8, 0.05);
        EXPECT_NEAR(scene.OccluderCoverage(f), 0.8, 1e-12);
        double lo = 0, hi = 0;
        cv::Mat depth;
        frame.depth.convertTo(depth, CV_64F, 1.0 / options.sensor.depth_map_factor);
        cv::minMaxLoc(depth, &lo, &hi, nullptr, nullptr, on_occluder);
        EXPECT_GT(lo, options.occluder_distance - 0.03);  // its front, swaying a few cm
        EXPECT_LT(lo, options.occluder_distance + 0.03);
        EXPECT_EQ(boxed, !undetected);
      }
      // The mask marks it as moving whether or not it is boxed.
      EXPECT_EQ(cv::countNonZero(on_occluder & ~frame.dynamic_mask), 0);
    }
  }
  SyntheticOptions bad = SmallOptions();
  bad.occluder_coverage = 0.99;
  EXPECT_THROW(bad.Check(), InvalidOptions);
  bad.occluder_coverage = 0.5;
  bad.occluder_distance = 0.2;
  EXPECT_THROW(bad.Check(), InvalidOptions);
}

}  // namespace
}  // namespace dygslam
