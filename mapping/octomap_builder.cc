#include "mapping/octomap_builder.h"

#include <octomap/AbstractOcTree.h>
#include <octomap/OcTree.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <unordered_map>

#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/io/file_util.h"
#include "mapping/scan_inserter.h"

namespace dygslam {
namespace {

// CPU time of the calling thread (not inflated by other processes sharing the cores).
double ThreadCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

double MillisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

std::string KeyframeName(const KeyframeData& keyframe) {
  return "keyframe " + std::to_string(keyframe.id) + " (stamp " + keyframe.stamp.ToString() + ")";
}

// Voxel-grid filter: one point (the centroid) per cell of size `leaf`.
std::vector<Eigen::Vector3f> VoxelGridFilter(const std::vector<Eigen::Vector3f>& points,
                                             double leaf) {
  struct Cell {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    int count = 0;
    size_t first = 0;  // keeps the output order deterministic
  };
  const double inv = 1.0 / leaf;
  std::unordered_map<uint64_t, Cell> cells;
  cells.reserve(points.size() / 4 + 16);
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f& p = points[i];
    // 21 bits per axis around an offset: +-52 km at 5 cm cells, far beyond any sensor range.
    const auto index = [inv](float v) {
      return static_cast<uint64_t>(static_cast<int64_t>(std::floor(v * inv)) + (1 << 20)) &
             0x1fffff;
    };
    const uint64_t key = (index(p.x()) << 42) | (index(p.y()) << 21) | index(p.z());
    auto [it, inserted] = cells.try_emplace(key);
    if (inserted) it->second.first = i;
    it->second.sum += p.cast<double>();
    ++it->second.count;
  }
  std::vector<std::pair<size_t, Eigen::Vector3f>> ordered;
  ordered.reserve(cells.size());
  for (const auto& [key, cell] : cells) {
    ordered.emplace_back(cell.first, (cell.sum / cell.count).cast<float>());
  }
  std::sort(ordered.begin(), ordered.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<Eigen::Vector3f> out;
  out.reserve(ordered.size());
  for (const auto& entry : ordered) out.push_back(entry.second);
  return out;
}

}  // namespace

void OctoMapOptions::Check() const {
  DYGSLAM_CHECK_OPTION(resolution > 0.001 && resolution <= 10 && std::isfinite(resolution),
                       "OctoMap.resolution");
  DYGSLAM_CHECK_OPTION(max_range > 0 && max_range <= 1000, "OctoMap.max_range");  // m
  DYGSLAM_CHECK_OPTION(min_range >= 0 && min_range < max_range, "OctoMap.min_range");
  DYGSLAM_CHECK_OPTION(prob_hit > 0.5 && prob_hit < 1, "OctoMap.prob_hit");
  DYGSLAM_CHECK_OPTION(prob_miss > 0 && prob_miss < 0.5, "OctoMap.prob_miss");
  DYGSLAM_CHECK_OPTION(clamping_min > 0 && clamping_min < occupancy_threshold,
                       "OctoMap.clamping_min");
  DYGSLAM_CHECK_OPTION(clamping_max < 1 && clamping_max > occupancy_threshold,
                       "OctoMap.clamping_max");
  DYGSLAM_CHECK_OPTION(occupancy_threshold > 0 && occupancy_threshold < 1,
                       "OctoMap.occupancy_threshold");
  DYGSLAM_CHECK_OPTION(pixel_stride >= 1 && pixel_stride <= 64, "OctoMap.pixel_stride");
  DYGSLAM_CHECK_OPTION(dynamic_mask_dilation_px >= 0 && dynamic_mask_dilation_px <= 200,
                       "OctoMap.dynamic_mask_dilation_px");
  DYGSLAM_CHECK_OPTION(dynamic_keypoint_radius_px >= 0 && dynamic_keypoint_radius_px <= 200,
                       "OctoMap.dynamic_keypoint_radius_px");
  DYGSLAM_CHECK_OPTION(std::isfinite(rebuild_displacement), "OctoMap.rebuild_displacement");
}

OctoMapBuilder::OctoMapBuilder(const PinholeCamera& camera, const OctoMapOptions& options)
    : camera_(camera), options_(options), inserter_(std::make_unique<ScanInserter>()) {
  camera_.Check();
  options_.Check();
  ResetTree();
}

OctoMapBuilder::~OctoMapBuilder() = default;

void OctoMapBuilder::SetBaseMap(const octomap::OcTree& base, const std::string& source) {
  if (std::abs(base.getResolution() - options_.resolution) > 1e-9)
    throw InputError(source, 0,
                     "OctoMap resolution " + ExactNumber(base.getResolution()) +
                         " m differs from OctoMap.resolution " + ExactNumber(options_.resolution) +
                         " m of the settings");
  base_ = std::make_unique<octomap::OcTree>(base);
  ResetTree();
  for (auto& [id, keyframe] : keyframes_) InsertIntoTree(keyframe);
}

void OctoMapBuilder::ResetTree() {
  tree_ = base_ ? std::make_unique<octomap::OcTree>(*base_)
                : std::make_unique<octomap::OcTree>(options_.resolution);
  tree_->setProbHit(options_.prob_hit);
  tree_->setProbMiss(options_.prob_miss);
  tree_->setClampingThresMin(options_.clamping_min);
  tree_->setClampingThresMax(options_.clamping_max);
  tree_->setOccupancyThres(options_.occupancy_threshold);
  inner_dirty_ = false;
}

StaticCloud OctoMapBuilder::ExtractStaticCloud(const KeyframeData& keyframe) const {
  return dygslam::ExtractStaticCloud(keyframe, camera_, options_);
}

StaticCloud ExtractStaticCloud(const KeyframeData& keyframe, const PinholeCamera& camera_,
                               const OctoMapOptions& options_) {
  const cv::Mat& depth = keyframe.depth;
  if (depth.empty()) throw InputError(KeyframeName(keyframe) + ": depth is empty");
  if (depth.type() != CV_32FC1) {
    throw InputError(KeyframeName(keyframe) + ": depth must be CV_32FC1 metres, got type " +
                     std::to_string(depth.type()));
  }
  if (depth.cols != camera_.width || depth.rows != camera_.height) {
    throw InputError(KeyframeName(keyframe) + ": depth is " + std::to_string(depth.cols) + "x" +
                     std::to_string(depth.rows) + ", camera is " + std::to_string(camera_.width) +
                     "x" + std::to_string(camera_.height));
  }

  // Pixels to leave out: dilated dynamic mask + disks around dynamic keypoints.
  cv::Mat excluded;
  if (options_.use_dynamic_mask) {
    const cv::Mat& mask = keyframe.dynamic_mask;
    if (!mask.empty()) {
      if (mask.type() != CV_8UC1 || mask.size() != depth.size()) {
        throw InputError(KeyframeName(keyframe) +
                         ": dynamic_mask must be CV_8UC1 of the depth size");
      }
      excluded = mask > 0;
      if (options_.dynamic_mask_dilation_px > 0) {
        const int r = options_.dynamic_mask_dilation_px;
        cv::dilate(excluded, excluded,
                   cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * r + 1, 2 * r + 1)));
      }
    }
    if (!keyframe.keypoint_dynamic.empty() && options_.dynamic_keypoint_radius_px > 0) {
      if (keyframe.keypoint_dynamic.size() != keyframe.keypoints.size()) {
        throw InputError(KeyframeName(keyframe) + ": keypoint_dynamic has " +
                         std::to_string(keyframe.keypoint_dynamic.size()) + " entries for " +
                         std::to_string(keyframe.keypoints.size()) + " keypoints");
      }
      if (excluded.empty()) excluded = cv::Mat::zeros(depth.size(), CV_8UC1);
      for (size_t i = 0; i < keyframe.keypoints.size(); ++i) {
        if (!keyframe.keypoint_dynamic[i]) continue;
        cv::circle(
            excluded,
            cv::Point(cvRound(keyframe.keypoints[i].pt.x), cvRound(keyframe.keypoints[i].pt.y)),
            options_.dynamic_keypoint_radius_px, cv::Scalar(255), cv::FILLED);
      }
    }
  }

  StaticCloud result;
  std::vector<Eigen::Vector3f> points;
  const int stride = options_.pixel_stride;
  points.reserve(static_cast<size_t>(depth.rows / stride + 1) * (depth.cols / stride + 1));
  const float min_range = static_cast<float>(options_.min_range);
  for (int v = 0; v < depth.rows; v += stride) {
    const float* drow = depth.ptr<float>(v);
    const uint8_t* erow = excluded.empty() ? nullptr : excluded.ptr<uint8_t>(v);
    for (int u = 0; u < depth.cols; u += stride) {
      const float d = drow[u];
      if (!std::isfinite(d) || d < min_range || d <= 0.f) continue;
      ++result.num_valid_pixels;
      if (erow != nullptr && erow[u] != 0) {
        ++result.num_dynamic_pixels;
        continue;
      }
      points.push_back(camera_.Unproject(u, v, d).cast<float>());
    }
  }
  result.points_cam =
      options_.use_voxel_filter ? VoxelGridFilter(points, options_.resolution) : std::move(points);
  return result;
}

void OctoMapBuilder::InsertIntoTree(const StoredKeyframe& keyframe) {
  const Eigen::Matrix3f rotation = keyframe.world_from_cam.RotationMatrix().cast<float>();
  const Eigen::Vector3f translation = keyframe.world_from_cam.translation.cast<float>();
  octomap::Pointcloud cloud;
  cloud.reserve(keyframe.points_cam.size());
  for (const Eigen::Vector3f& p : keyframe.points_cam) {
    const Eigen::Vector3f w = rotation * p + translation;
    cloud.push_back(w.x(), w.y(), w.z());
  }
  const octomap::point3d origin(translation.x(), translation.y(), translation.z());
  inserter_->Insert(*tree_, cloud, origin, options_.max_range, options_.lazy_eval);
  if (options_.lazy_eval) inner_dirty_ = true;
  ++num_insertions_;
}

bool OctoMapBuilder::NeedsRebuild(const Rigid3d& a, const Rigid3d& b) const {
  const double dt = (a.translation - b.translation).norm();
  const double angle = RotationAngle(a.rotation.conjugate() * b.rotation);
  return dt + angle * options_.max_range > options_.EffectiveRebuildDisplacement();
}

void OctoMapBuilder::CheckInsertable(const KeyframeData& keyframe) {
  if (keyframe.removed || keyframe.pose_update_only) {
    throw InputError(KeyframeName(keyframe) + ": " +
                     (keyframe.removed ? "removed" : "pose_update_only") +
                     " is not a keyframe to insert (KeyframeConsumer applies those)");
  }
  if (!keyframe.world_from_cam.AllFinite()) {
    throw InputError(KeyframeName(keyframe) + ": world_from_cam is not finite");
  }
}

void OctoMapBuilder::Insert(const KeyframeData& keyframe) {
  CheckInsertable(keyframe);
  if (keyframes_.count(keyframe.id) > 0 && keyframe.depth.empty()) {
    UpdatePoses({{keyframe.id, keyframe.world_from_cam}});
    return;
  }
  InsertCloud(keyframe, std::nullopt);
}

void OctoMapBuilder::Insert(const KeyframeData& keyframe, StaticCloud cloud) {
  CheckInsertable(keyframe);
  InsertCloud(keyframe, std::move(cloud));
}

void OctoMapBuilder::InsertCloud(const KeyframeData& keyframe, std::optional<StaticCloud> cloud) {
  auto known = keyframes_.find(keyframe.id);
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = ThreadCpuMs();
  StoredKeyframe stored;
  stored.points_cam =
      cloud ? std::move(cloud->points_cam) : ExtractStaticCloud(keyframe).points_cam;
  stored.sequence = next_sequence_++;
  stored.world_from_cam = keyframe.world_from_cam;
  stored.inserted_world_from_cam = keyframe.world_from_cam;

  if (known != keyframes_.end()) {
    // Replacement: the old contribution has to go, which needs a rebuild.
    known->second = std::move(stored);
    rebuild_pending_ = true;
    return;
  }
  auto [it, inserted] = keyframes_.emplace(keyframe.id, std::move(stored));
  // Inserted now even when a rebuild is pending, so the map stays live; the rebuild re-inserts it.
  InsertIntoTree(it->second);
  last_insert_ms_ = MillisecondsSince(start);
  insert_ms_.push_back(last_insert_ms_);
  insert_cpu_ms_.push_back(ThreadCpuMs() - cpu_start);
}

size_t OctoMapBuilder::UpdatePoses(const std::map<int64_t, Rigid3d>& world_from_cam) {
  size_t known = 0;
  for (const auto& [id, pose] : world_from_cam) {
    auto it = keyframes_.find(id);
    if (it == keyframes_.end()) continue;
    if (!pose.AllFinite()) {
      throw InputError("keyframe " + std::to_string(id) +
                       ": corrected world_from_cam is not finite");
    }
    ++known;
    it->second.world_from_cam = pose;
    if (NeedsRebuild(pose, it->second.inserted_world_from_cam)) rebuild_pending_ = true;
  }
  return known;
}

bool OctoMapBuilder::Remove(int64_t keyframe_id) {
  if (keyframes_.erase(keyframe_id) == 0) return false;
  rebuild_pending_ = true;
  return true;
}

void OctoMapBuilder::Rebuild() {
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = ThreadCpuMs();
  ResetTree();
  std::vector<StoredKeyframe*> ordered;
  ordered.reserve(keyframes_.size());
  for (auto& [id, keyframe] : keyframes_) ordered.push_back(&keyframe);
  std::sort(ordered.begin(), ordered.end(), [](const StoredKeyframe* a, const StoredKeyframe* b) {
    return a->sequence < b->sequence;
  });
  for (StoredKeyframe* keyframe : ordered) {
    InsertIntoTree(*keyframe);
    keyframe->inserted_world_from_cam = keyframe->world_from_cam;
  }
  rebuild_pending_ = false;
  ++num_rebuilds_;
  last_rebuild_ms_ = MillisecondsSince(start);
  last_rebuild_cpu_ms_ = ThreadCpuMs() - cpu_start;
}

void OctoMapBuilder::Sync() {
  if (rebuild_pending_) Rebuild();
  if (inner_dirty_) {
    tree_->updateInnerOccupancy();
    tree_->prune();
    inner_dirty_ = false;
  }
}

void OctoMapBuilder::Finalize() {
  for (const auto& entry : keyframes_) {
    const StoredKeyframe& keyframe = entry.second;
    if (keyframe.world_from_cam.translation != keyframe.inserted_world_from_cam.translation ||
        keyframe.world_from_cam.rotation.coeffs() !=
            keyframe.inserted_world_from_cam.rotation.coeffs()) {
      rebuild_pending_ = true;
      break;
    }
  }
  Sync();
}

const octomap::OcTree& OctoMapBuilder::tree() {
  Sync();
  return *tree_;
}

std::vector<int64_t> OctoMapBuilder::KeyframeIds() const {
  std::vector<int64_t> ids;
  ids.reserve(keyframes_.size());
  for (const auto& entry : keyframes_) ids.push_back(entry.first);
  return ids;
}

const Rigid3d& OctoMapBuilder::Pose(int64_t keyframe_id) const {
  return keyframes_.at(keyframe_id).world_from_cam;
}

OctoMapStats OctoMapBuilder::Stats() {
  Sync();
  OctoMapStats stats;
  stats.num_keyframes = keyframes_.size();
  for (const auto& entry : keyframes_) stats.num_stored_points += entry.second.points_cam.size();
  const unsigned max_depth = tree_->getTreeDepth();
  for (auto it = tree_->begin_leafs(), end = tree_->end_leafs(); it != end; ++it) {
    ++stats.num_leaves;
    const uint64_t voxels = uint64_t{1} << (3 * (max_depth - it.getDepth()));
    if (tree_->isNodeOccupied(*it)) {
      ++stats.num_occupied_leaves;
      stats.num_occupied_voxels += voxels;
    } else {
      ++stats.num_free_leaves;
      stats.num_free_voxels += voxels;
    }
  }
  stats.memory_bytes = tree_->memoryUsage();
  stats.num_insertions = num_insertions_;
  stats.num_rebuilds = num_rebuilds_;
  stats.last_insert_ms = last_insert_ms_;
  stats.last_rebuild_ms = last_rebuild_ms_;
  stats.last_rebuild_cpu_ms = last_rebuild_cpu_ms_;
  if (!insert_ms_.empty()) {
    std::vector<double> sorted = insert_ms_;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    stats.median_insert_ms = sorted[sorted.size() / 2];
    sorted = insert_cpu_ms_;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    stats.median_insert_cpu_ms = sorted[sorted.size() / 2];
  }
  return stats;
}

void OctoMapBuilder::WriteBinary(const std::string& path) {
  Sync();
  WriteOctoMapBinary(*tree_, path);
}

void OctoMapBuilder::WriteFull(const std::string& path) {
  Sync();
  WriteOctoMapFull(*tree_, path);
}

}  // namespace dygslam
