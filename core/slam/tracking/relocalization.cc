#include "core/slam/tracking/relocalization.h"

#include <algorithm>
#include <opencv2/calib3d.hpp>
#include <set>

#include "core/slam/map/place_recognition.h"

namespace dygslam {
namespace {

// The keyframes to try: by the bag of words when there is a vocabulary, else every keyframe
// ranked by descriptor matches to its map points (brute force).
std::vector<std::shared_ptr<KeyFrame>> RelocalizationCandidatesFor(
    Frame& frame, const Map& map, const KeyFrameDatabase* database, const Vocabulary* vocabulary,
    const Matcher& matcher, const TrackingOptions& options, bool use_bow) {
  if (use_bow) {
    frame.ComputeBow(*vocabulary);
    PlaceRecognitionOptions place = options.place;
    place.max_candidates = std::max(place.max_candidates, options.relocalization_candidates);
    return RelocalizationCandidates(map, *database, frame.bow_vector, place);
  }
  std::vector<std::pair<int, std::shared_ptr<KeyFrame>>> ranked;
  for (const auto& [id, kf] : map.keyframes()) {
    Frame probe = frame;
    std::fill(probe.map_points.begin(), probe.map_points.end(), nullptr);
    const int n = matcher.SearchByDescriptors(*kf, probe, 0.75);
    if (n >= 15) ranked.push_back({n, kf});
  }
  std::stable_sort(ranked.begin(), ranked.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  if (static_cast<int>(ranked.size()) > options.relocalization_candidates)
    ranked.resize(options.relocalization_candidates);
  std::vector<std::shared_ptr<KeyFrame>> candidates;
  for (const auto& r : ranked) candidates.push_back(r.second);
  return candidates;
}

// The frame's pose by EPnP RANSAC on its matched map points (the outliers' matches dropped);
// false when there are too few matches or inliers.
bool SolvePnpPose(Frame& frame) {
  std::vector<cv::Point3f> object;
  std::vector<cv::Point2f> image;
  std::vector<size_t> index;
  for (size_t i = 0; i < frame.size(); ++i) {
    const auto& mp = frame.map_points[i];
    if (!mp) continue;
    object.emplace_back(float(mp->position.x()), float(mp->position.y()), float(mp->position.z()));
    image.push_back(frame.undistorted[i].pt);
    index.push_back(i);
  }
  if (object.size() < 15) return false;
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  cv::setRNGSeed(static_cast<int>(frame.id));
  const bool solved =
      cv::solvePnPRansac(object, image, frame.geometry->camera.K(), cv::noArray(), rvec, tvec,
                         false, 200, 4.0f, 0.99, inliers, cv::SOLVEPNP_EPNP);
  if (!solved || inliers.size() < 10) return false;
  cv::Mat rmat;
  cv::Rodrigues(rvec, rmat);
  Eigen::Matrix3d r;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) r(a, b) = rmat.at<double>(a, b);
  frame.cam_from_world =
      Rigid3d(r, Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)));
  frame.has_pose = true;
  std::vector<uint8_t> keep(frame.size(), 0);
  for (int in : inliers) keep[index[in]] = 1;
  for (size_t i = 0; i < frame.size(); ++i)
    if (!keep[i]) frame.map_points[i] = nullptr;
  return true;
}

}  // namespace

RelocalizationResult RelocalizeFrame(Frame& frame, const Map& map, const KeyFrameDatabase* database,
                                     const Vocabulary* vocabulary, const Matcher& matcher,
                                     const TrackingOptions& options) {
  RelocalizationResult result;
  const bool use_bow = database != nullptr && vocabulary != nullptr && !vocabulary->empty();
  const std::vector<std::shared_ptr<KeyFrame>> candidates =
      RelocalizationCandidatesFor(frame, map, database, vocabulary, matcher, options, use_bow);
  for (const auto& kf : candidates) {
    std::fill(frame.map_points.begin(), frame.map_points.end(), nullptr);
    std::fill(frame.outlier.begin(), frame.outlier.end(), 0);
    const int matched = use_bow ? matcher.SearchByBow(*kf, frame, 0.75)
                                : matcher.SearchByDescriptors(*kf, frame, 0.75);
    if (matched < 15) continue;
    ++result.candidates;
    if (!SolvePnpPose(frame)) continue;
    int good = OptimizePose(frame, options.optimizer);
    if (good < 10) continue;
    frame.DiscardOutliers();
    if (good < options.relocalized_min_inliers) {
      std::set<const MapPoint*> found;
      for (const auto& mp : frame.map_points)
        if (mp) found.insert(mp.get());
      matcher.SearchByProjection(frame, *kf, found, 10, 100);
      good = OptimizePose(frame, options.optimizer);
      frame.DiscardOutliers();
    }
    if (good >= options.relocalized_min_inliers) {
      result.ok = true;
      result.keyframe = kf;
      result.inliers = good;
      return result;
    }
  }
  std::fill(frame.map_points.begin(), frame.map_points.end(), nullptr);
  frame.has_pose = false;
  return result;
}

}  // namespace dygslam
