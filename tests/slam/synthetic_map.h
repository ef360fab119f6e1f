// A keyframe map made directly from a rendered synthetic sequence (ground-truth poses and depth,
// no tracking): keyframe k = frame k * stride, every feature with depth a map point. Used to test
// and time relocalization with a chosen number of keyframes without running SLAM for minutes.
#pragma once

#include <memory>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "core/place/keyframe_database.h"
#include "core/slam/map/frame.h"
#include "core/slam/map/map.h"
#include "tools/synth/synthetic_scene.h"

namespace dygslam::testing {

struct SyntheticMap {
  std::shared_ptr<const CameraGeometry> geometry;
  std::shared_ptr<Map> map = std::make_shared<Map>();
  KeyFrameDatabase database;
};

inline Frame MakeSyntheticFrame(const SyntheticScene& scene, const SyntheticFrame& f, int64_t id,
                                const OrbExtractor& extractor,
                                const std::shared_ptr<const CameraGeometry>& geometry) {
  cv::Mat gray, depth_m;
  cv::cvtColor(f.rgb, gray, cv::COLOR_BGR2GRAY);
  f.depth.convertTo(depth_m, CV_32F, 1.0 / scene.options().sensor.depth_map_factor);
  return Frame(id, f.stamp, extractor.Extract(gray), depth_m, geometry);
}

// Keyframes from frames 0, stride, 2 * stride, ... (num_keyframes of them).
inline void BuildSyntheticMap(const SyntheticScene& scene, int num_keyframes, int stride,
                              const Vocabulary& vocabulary, const OrbExtractor& extractor,
                              SyntheticMap* out) {
  out->geometry = std::make_shared<CameraGeometry>(
      CameraGeometry::Create(scene.options().camera, scene.options().sensor, extractor));
  Map& map = *out->map;
  std::lock_guard<std::mutex> lock(map.mutex());
  std::shared_ptr<KeyFrame> previous;
  for (int k = 0; k < num_keyframes; ++k) {
    const int index = k * stride;
    Frame frame =
        MakeSyntheticFrame(scene, scene.RenderFrame(index), index, extractor, out->geometry);
    frame.cam_from_world = scene.WorldFromCam(index).Inverse();
    frame.has_pose = true;
    frame.ComputeBow(vocabulary);
    auto kf = std::make_shared<KeyFrame>(map.NextKeyFrameId(), frame);
    map.AddKeyFrame(kf);
    for (size_t i = 0; i < kf->size(); ++i) {
      if (!kf->CanSeedPoint(i)) continue;
      auto mp = std::make_shared<MapPoint>(map.NextMapPointId(), kf->UnprojectWorld(i), kf->id);
      mp->ref_kf_id = kf->id;
      map.AddObservation(mp, kf, static_cast<int>(i));
      map.ComputeDistinctiveDescriptor(*mp);
      map.UpdateNormalAndDepth(*mp);
      map.AddMapPoint(mp);
    }
    out->database.Add(kf->id, kf->bow_vector);
  }
}

}  // namespace dygslam::testing
