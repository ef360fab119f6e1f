// The settings and a tiny valid map shared by map_file_fuzzer and make_fuzz_seeds: a 64 x 48
// camera, 2 ORB levels, two keyframes of 6 keypoints, 4 map points (one observed twice, with
// covisibility, BoW vector and direct index), so every section of the format has entries.
#pragma once

#include <memory>
#include <string>

#include "core/slam/map/map.h"
#include "core/slam/map/map_file.h"
#include "core/slam/feature/orb_extractor.h"

namespace dygslam::fuzz {

inline std::shared_ptr<const CameraGeometry> MapSeedGeometry() {
  static const std::shared_ptr<const CameraGeometry> geometry = [] {
    PinholeCamera camera;
    camera.fx = camera.fy = 50;
    camera.cx = 32;
    camera.cy = 24;
    camera.width = 64;
    camera.height = 48;
    OrbExtractorOptions orb;
    orb.num_levels = 2;
    orb.num_features = 50;
    const OrbExtractor extractor(orb);
    return std::make_shared<const CameraGeometry>(
        CameraGeometry::Create(camera, RgbdSensorOptions{}, extractor));
  }();
  return geometry;
}

inline MapFileSettings MapSeedSettings() {
  return MapFileSettings::Of(*MapSeedGeometry(), 1.2, 0x1234);
}

// The file bytes of the tiny map.
inline std::string MapSeedFile() {
  Map map;
  std::shared_ptr<KeyFrame> keyframes[2];
  for (int k = 0; k < 2; ++k) {
    Frame frame;
    frame.id = 10 * k;
    frame.stamp = Timestamp::FromNanoseconds(1'000'000'000LL * (k + 1));
    frame.geometry = MapSeedGeometry();
    frame.cam_from_world.translation = Eigen::Vector3d(0.1 * k, 0, 0);
    frame.has_pose = true;
    for (int i = 0; i < 6; ++i) {
      cv::KeyPoint kp(cv::Point2f(5.f + 9.f * i, 10.f + 4.f * i), 31.f, 10.f * i, 0.5f, i % 2);
      frame.keypoints.push_back(kp);
      frame.undistorted.push_back(kp);
      Descriptor d{};
      d[0] = 0x9e3779b97f4a7c15ULL * (i + 1);
      d[1] = 0xabcdefULL << i;
      frame.descriptors.push_back(d);
      frame.depth.push_back(i == 5 ? -1.f : 1.0f + 0.1f * i);
      frame.u_right.push_back(i == 5 ? -1.f : kp.pt.x - 40.f / (1.0f + 0.1f * i));
      frame.in_dynamic_region.push_back(i == 4 ? 1 : 0);
    }
    frame.bow_vector = {{3u, 0.5}, {7u, 0.25}, {11u, 0.25}};
    frame.bow_features = {{1u, {0, 2, 4}}, {2u, {1, 3, 5}}};
    frame.grid.Build(frame.undistorted, *frame.geometry);
    frame.map_points.assign(6, nullptr);
    frame.outlier.assign(6, 0);
    keyframes[k] = std::make_shared<KeyFrame>(map.NextKeyFrameId(), frame);
    map.AddKeyFrame(keyframes[k]);
  }
  keyframes[1]->parent_id = 0;
  for (int p = 0; p < 4; ++p) {
    auto mp =
        std::make_shared<MapPoint>(map.NextMapPointId(), Eigen::Vector3d(0.1 * p, 0.2, 1.5), 0);
    mp->ref_kf_id = 0;
    mp->normal = Eigen::Vector3d(0, 0, 1);
    mp->min_distance = 0.5;
    mp->max_distance = 3.0;
    map.AddObservation(mp, keyframes[0], p);
    if (p == 0) map.AddObservation(mp, keyframes[1], 1);
    map.AddMapPoint(mp);
  }
  keyframes[0]->connection_weights[1] = 1;
  keyframes[0]->ordered_connections = {1};
  keyframes[1]->connection_weights[0] = 1;
  keyframes[1]->ordered_connections = {0};
  return EncodeMapFile(map, MapSeedSettings());
}

}  // namespace dygslam::fuzz
