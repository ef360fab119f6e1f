// Pose-only optimisation and local bundle adjustment on generated observations.
#include "core/slam/optimize/optimizer.h"

#include <gtest/gtest.h>

#include <random>

#include "core/slam/map/map.h"

namespace dygslam {
namespace {

struct Scene {
  std::shared_ptr<CameraGeometry> geometry;
  std::vector<Eigen::Vector3d> points;
};

Scene MakeScene(int num_points, uint32_t seed) {
  Scene s;
  PinholeCamera cam;
  cam.fx = cam.fy = 525;
  cam.cx = 319.5;
  cam.cy = 239.5;
  OrbExtractor extractor{OrbExtractorOptions{}};
  RgbdSensorOptions sensor;
  s.geometry = std::make_shared<CameraGeometry>(CameraGeometry::Create(cam, sensor, extractor));
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> x(-1.5, 1.5), y(-1.0, 1.0), z(1.5, 5.0);
  for (int i = 0; i < num_points; ++i) s.points.emplace_back(x(rng), y(rng), z(rng));
  return s;
}

// A frame observing `points` from cam_from_world with pixel noise; a share of the matches are
// wrong (observation of another random pixel).
Frame MakeFrame(const Scene& s, const Rigid3d& cam_from_world, double noise_px,
                double outlier_share, uint32_t seed, std::vector<uint8_t>* is_outlier) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0, noise_px);
  std::uniform_real_distribution<double> u01(0, 1), upix(0, 640), vpix(0, 480);
  OrbFeatures features;
  cv::Mat depth(480, 640, CV_32F, cv::Scalar(0));
  std::vector<std::shared_ptr<MapPoint>> mps;
  is_outlier->clear();
  for (size_t i = 0; i < s.points.size(); ++i) {
    const Eigen::Vector3d p = cam_from_world * s.points[i];
    const Eigen::Vector2d uv = s.geometry->camera.Project(p);
    if (!s.geometry->InBounds(uv.x(), uv.y())) continue;
    const bool wrong = u01(rng) < outlier_share;
    cv::KeyPoint kp;
    kp.pt = wrong ? cv::Point2f(float(upix(rng)), float(vpix(rng)))
                  : cv::Point2f(float(uv.x() + noise(rng)), float(uv.y() + noise(rng)));
    kp.pt.x = std::clamp(kp.pt.x, 0.f, 639.f);
    kp.pt.y = std::clamp(kp.pt.y, 0.f, 479.f);
    kp.octave = 0;
    features.keypoints.push_back(kp);
    features.descriptors.push_back(Descriptor{});
    if (!wrong) depth.at<float>(cvRound(kp.pt.y), cvRound(kp.pt.x)) = float(p.z());
    mps.push_back(std::make_shared<MapPoint>(int64_t(i), s.points[i], 0));
    is_outlier->push_back(wrong);
  }
  Frame f(1, Timestamp::FromNanoseconds(1), features, depth, s.geometry);
  for (size_t i = 0; i < f.size(); ++i) f.map_points[i] = mps[i];
  return f;
}

TEST(Optimizer, PoseOnlyRecoversPoseWithOutliers) {
  const Scene s = MakeScene(400, 1);
  const Rigid3d truth(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.1, Eigen::Vector3d(0.3, 1, 0.2).normalized())),
      Eigen::Vector3d(0.2, -0.1, 0.3));
  std::vector<uint8_t> wrong;
  Frame f = MakeFrame(s, truth, 0.5, 0.2, 2, &wrong);
  ASSERT_GT(f.size(), 200u);
  // Start 5 cm / 2 degrees away.
  f.cam_from_world = Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.035, Eigen::Vector3d::UnitZ())),
                             Eigen::Vector3d(0.05, 0, 0)) *
                     truth;
  const int inliers = OptimizePose(f, OptimizerOptions{});
  EXPECT_LT((f.cam_from_world.translation - truth.translation).norm(), 0.005);
  EXPECT_LT(RotationAngle(f.cam_from_world.rotation * truth.rotation.conjugate()), 0.002);
  int flagged_wrong = 0, flagged_right = 0, num_wrong = 0;
  for (size_t i = 0; i < f.size(); ++i) {
    num_wrong += wrong[i];
    if (f.outlier[i]) (wrong[i] ? flagged_wrong : flagged_right)++;
  }
  EXPECT_GE(flagged_wrong, 0.9 * num_wrong);               // wrong matches rejected
  EXPECT_LE(flagged_right, 0.1 * (f.size() - num_wrong));  // right ones kept
  EXPECT_EQ(inliers, static_cast<int>(f.size()) - flagged_wrong - flagged_right);
}

// Four keyframes 0.1 m apart observing 300 points (0.3 px noise), at their true poses.
struct KeyFrameScene {
  std::shared_ptr<Map> map = std::make_shared<Map>();
  std::vector<Rigid3d> truths;
  std::vector<std::shared_ptr<KeyFrame>> kfs;
};

KeyFrameScene MakeKeyFrameScene() {
  KeyFrameScene scene;
  const Scene s = MakeScene(300, 3);
  auto& map = scene.map;
  auto& truths = scene.truths;
  auto& kfs = scene.kfs;
  std::vector<std::shared_ptr<MapPoint>> points;
  for (size_t i = 0; i < s.points.size(); ++i) {
    points.push_back(std::make_shared<MapPoint>(map->NextMapPointId(), s.points[i], 0));
  }
  for (int k = 0; k < 4; ++k) {
    const Rigid3d truth(Eigen::Quaterniond(Eigen::AngleAxisd(0.05 * k, Eigen::Vector3d::UnitY())),
                        Eigen::Vector3d(0.1 * k, 0.02 * k, 0));
    truths.push_back(truth);
    std::vector<uint8_t> wrong;
    Frame f = MakeFrame(s, truth, 0.3, 0.0, 10 + k, &wrong);
    f.cam_from_world = truth;
    auto kf = std::make_shared<KeyFrame>(map->NextKeyFrameId(), f);
    map->AddKeyFrame(kf);
    kfs.push_back(kf);
  }
  {
    std::lock_guard<std::mutex> lock(map->mutex());
    for (const auto& kf : kfs) {
      for (size_t i = 0; i < kf->size(); ++i) {
        const int64_t pid = kf->map_points[i]->id;  // MakeFrame used the point index as id
        kf->map_points[i] = nullptr;
        map->AddObservation(points[pid], kf, static_cast<int>(i));
      }
    }
    for (const auto& mp : points) {
      if (mp->observations.empty()) continue;
      mp->ref_kf_id = mp->observations.begin()->first;
      map->AddMapPoint(mp);
      map->UpdateNormalAndDepth(*mp);
    }
    for (const auto& kf : kfs) map->UpdateConnections(kf);
  }
  return scene;
}

TEST(Optimizer, LocalBundleAdjustmentPullsPerturbedKeyframeBack) {
  KeyFrameScene scene = MakeKeyFrameScene();
  auto& map = scene.map;
  const auto& truths = scene.truths;
  const auto& kfs = scene.kfs;
  {
    std::lock_guard<std::mutex> lock(map->mutex());
    // Perturb the newest keyframe by 4 cm.
    kfs[3]->cam_from_world =
        Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.04, -0.02, 0.01)) * truths[3];
  }
  LocalBundleAdjustment(*map, kfs[3], OptimizerOptions{});
  std::lock_guard<std::mutex> lock(map->mutex());
  EXPECT_LT((kfs[3]->cam_from_world.translation - truths[3].translation).norm(), 0.005);
  EXPECT_LT((kfs[0]->cam_from_world.translation - truths[0].translation).norm(),
            1e-9);  // gauge fixed
}

TEST(Optimizer, GlobalBundleAdjustmentPullsEveryPerturbedKeyframeBackWithTheFirstFixed) {
  KeyFrameScene scene = MakeKeyFrameScene();
  auto& map = scene.map;
  const auto& truths = scene.truths;
  const auto& kfs = scene.kfs;
  const std::vector<Eigen::Vector3d> shifts = {
      {0, 0, 0}, {0.03, 0.01, -0.02}, {-0.02, 0.03, 0.01}, {0.04, -0.02, 0.01}};
  {
    std::lock_guard<std::mutex> lock(map->mutex());
    for (size_t k = 0; k < kfs.size(); ++k)
      kfs[k]->cam_from_world = Rigid3d(Eigen::Quaterniond::Identity(), shifts[k]) * truths[k];
  }
  GlobalBundleAdjustment(*map, OptimizerOptions{}, 10, 10);
  std::lock_guard<std::mutex> lock(map->mutex());
  for (size_t k = 1; k < kfs.size(); ++k) {
    // 2-4 cm off before; the points are at their true positions, so the poses come back.
    EXPECT_LT((kfs[k]->cam_from_world.translation - truths[k].translation).norm(), 0.005) << k;
  }
  // The gauge: the first keyframe is fixed.
  EXPECT_LT((kfs[0]->cam_from_world.translation - truths[0].translation).norm(), 1e-9);
}

}  // namespace
}  // namespace dygslam
