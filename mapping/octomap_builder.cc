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
    : camera_(camera), options_(options) {
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
  tree_->insertPointCloud(cloud, origin, options_.max_range, options_.lazy_eval,
                          /*discretize=*/false);
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

void WriteOctoMapBinaryStream(const octomap::OcTree& tree, std::ostream& out) {
  // The header AbstractOccupancyOcTree::writeBinaryConst writes, then the nodes depth first.
  out << "# Octomap OcTree binary file\n"
      << "# (feel free to add / change comments, but leave the first line as it is!)\n#\n";
  out << "id " << tree.getTreeType() << "\n";
  out << "size " << tree.size() << "\n";
  out << "res " << tree.getResolution() << "\n";
  out << "data\n";
  if (tree.getRoot() != nullptr) tree.writeBinaryNode(out, tree.getRoot());
}

void WriteOctoMapBinary(const octomap::OcTree& tree, const std::string& path) {
  std::ostringstream out(std::ios::binary);
  WriteOctoMapBinaryStream(tree, out);
  if (!out) throw InputError(path, 0, "cannot serialise the OcTree (.bt)");
  WriteFileAtomically(path, out.str());
}

void WriteOctoMapFull(const octomap::OcTree& tree, const std::string& path) {
  std::ostringstream out(std::ios::binary);
  if (!tree.write(out)) throw InputError(path, 0, "cannot serialise the OcTree (.ot)");
  WriteFileAtomically(path, out.str());
}

namespace {

// What an OctoMap file's text header says: the node count ("size N", -1 if none) and where the
// node data starts (after the "data" line; -1 if the header has none within 32 lines).
struct OctoMapHeader {
  std::string id;  // the tree type ("id OcTree")
  long long size = -1;
  std::streamoff data_at = -1;
};

OctoMapHeader ReadOctoMapHeader(std::istream& in) {
  OctoMapHeader header;
  std::string line;
  for (int k = 0; k < 32 && std::getline(in, line); ++k) {
    if (line == "data") {
      header.data_at = in.tellg();
      break;
    }
    if (line.rfind("id ", 0) == 0) header.id = line.substr(3);
    if (line.rfind("size ", 0) == 0) {
      try {
        header.size = std::stoll(line.substr(5));
      } catch (const std::exception&) {
        header.size = -1;
      }
    }
  }
  in.clear();
  in.seekg(0);
  return header;
}

// OctoMap's trees have 16 levels below the root; its readers recurse once per level a file
// declares, without a limit, so a crafted chain of a million nested nodes overflowed the stack.
constexpr int kOctoMapMaxDepth = 16;

// Walks the node data of an OctoMap file without recursion, in the order OctoMap's reader takes
// it, before that reader sees the file: nodes nested deeper than the tree's 16 levels, data that
// ends before the last node, and a node count other than the header's are errors naming the file.
//   .bt (binary): per inner node 2 bytes, 2 bits per child (11: the child has children, its own
//                 record follows depth-first; 01 / 10: an occupied / free leaf; 00: no child).
//   .ot (full):   per node its value (a 4-byte float for an OcTree) and 1 byte of child bits; each
//                 set bit is a child whose record follows depth-first.
void CheckOctoMapShape(const std::string& path, std::istream& in, const OctoMapHeader& header,
                       bool binary, const char* kind) {
  if (header.data_at < 0) {
    throw InputError(path, 0, std::string("malformed ") + kind + ": no 'data' line in the header");
  }
  // Other tree types' nodes hold more than a float (a ColorOcTree's also a colour).
  if (!header.id.empty() && header.id != "OcTree") {
    throw InputError(path, 0,
                     "OctoMap file holds a " + EchoValue(header.id) + ", expected an OcTree");
  }
  // An empty tree ("size 0") has no node data; OctoMap's readers then read none either.
  if (header.size == 0) return;
  in.clear();
  in.seekg(header.data_at);
  std::vector<char> chunk(1 << 16);
  size_t have = 0, at = 0;
  long long records = 0;
  const size_t record_size = binary ? 2 : 5;
  // The next node record's bytes, or nullptr where the data ends.
  auto next_record = [&]() -> const unsigned char* {
    if (have - at < record_size) {
      std::copy(chunk.begin() + static_cast<std::ptrdiff_t>(at),
                chunk.begin() + static_cast<std::ptrdiff_t>(have), chunk.begin());
      have -= at;
      at = 0;
      in.read(chunk.data() + have, static_cast<std::streamsize>(chunk.size() - have));
      have += static_cast<size_t>(in.gcount());
      if (have < record_size) return nullptr;
    }
    const auto* record = reinterpret_cast<const unsigned char*>(chunk.data() + at);
    at += record_size;
    ++records;
    return record;
  };
  auto fail = [&](const std::string& what) {
    throw InputError(path, 0,
                     std::string("truncated or corrupt ") + kind + ": " + what + " (the header " +
                         "declares " + std::to_string(header.size) + " nodes)");
  };
  // Per open node: its depth and how many of its children still have a record to come.
  struct Open {
    int depth;
    int pending;
  };
  std::vector<Open> open;
  long long nodes = 0;
  auto too_deep = [&]() {
    fail("nodes are nested deeper than the tree's " + std::to_string(kOctoMapMaxDepth) +
         " levels (node record " + std::to_string(records) + ")");
  };
  // Reads one node's record at `depth` and opens it; throws where the data ends.
  auto read_node = [&](int depth) {
    const unsigned char* record = next_record();
    if (record == nullptr) fail("the data ends after " + std::to_string(records) + " node records");
    if (depth > kOctoMapMaxDepth) too_deep();
    int pending = 0;
    ++nodes;
    if (binary) {
      for (int b = 0; b < 2; ++b) {
        for (int i = 0; i < 4; ++i) {
          const int code = (record[b] >> (2 * i)) & 3;
          if (code != 0 && depth + 1 > kOctoMapMaxDepth) too_deep();
          if (code == 3)
            ++pending;  // its record follows
          else if (code != 0)
            ++nodes;  // a leaf, no record of its own
        }
      }
    } else {
      const unsigned char bits = record[4];
      for (int i = 0; i < 8; ++i) pending += (bits >> i) & 1;
    }
    open.push_back({depth, pending});
  };
  read_node(0);
  while (!open.empty()) {
    Open& top = open.back();
    if (top.pending == 0) {
      open.pop_back();
      continue;
    }
    --top.pending;
    read_node(top.depth + 1);
  }
  if (header.size >= 0 && nodes != header.size) {
    fail("the data holds " + std::to_string(nodes) + " nodes");
  }
  in.clear();
  in.seekg(0);
}

// OctoMap's readers take what they can: a truncated file gives a smaller tree and no error. The
// stream must have delivered every byte asked for, and the tree must hold the declared nodes.
void CheckOctoMapComplete(const std::string& path, const std::istream& in, long long declared,
                          size_t read, const char* kind) {
  if (in.fail() || (declared >= 0 && static_cast<long long>(read) != declared)) {
    throw InputError(path, 0,
                     std::string("truncated or corrupt ") + kind + ": the header declares " +
                         std::to_string(declared) + " nodes, " + std::to_string(read) +
                         " were read before the data " + (in.fail() ? "ended" : "ran out"));
  }
}

}  // namespace

std::unique_ptr<octomap::OcTree> ReadOctoMap(const std::string& path) {
  // A binary input is read from a regular file only: a FIFO nobody writes into would block the
  // open forever, and the reader seeks back to the start.
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw InputError(path, 0, "OctoMap file not found");
  if (!std::filesystem::is_regular_file(path, ec))
    throw InputError(path, 0,
                     "OctoMap file is not a regular file (a FIFO, a device or a folder); OctoMaps "
                     "are read from regular files");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open OctoMap file");
  // The first line, at most 64 bytes (a file without a line end is not read whole).
  std::string header;
  for (char c; header.size() < 64 && in.get(c) && c != '\n';) header += c;
  in.clear();
  in.seekg(0);
  if (header.rfind("# Octomap OcTree binary file", 0) == 0) {
    const OctoMapHeader file_header = ReadOctoMapHeader(in);
    const long long declared = file_header.size;
    CheckOctoMapShape(path, in, file_header, /*binary=*/true, "binary OctoMap (.bt)");
    auto tree = std::make_unique<octomap::OcTree>(0.1);
    if (!tree->readBinary(in))
      throw InputError(path, 0,
                       "truncated or corrupt binary OctoMap (.bt): the nodes its header declares "
                       "could not be read");
    CheckOctoMapComplete(path, in, declared, tree->size(), "binary OctoMap (.bt)");
    return tree;
  }
  if (header.rfind("# Octomap OcTree file", 0) == 0) {
    const OctoMapHeader file_header = ReadOctoMapHeader(in);
    const long long declared = file_header.size;
    // OctoMap's .ot reader recurses on each node's child bits; past the end of the stream it read
    // an uninitialised byte as those bits and recursed until the stack overflowed (ASan,
    // reliability/OctoMapFiles.TruncatedOctoMapIsAnError), and a crafted chain of nested nodes
    // did the same (reliability/OctoMapFiles.DeeplyNestedOctoMapIsAnError): the walk checks both.
    CheckOctoMapShape(path, in, file_header, /*binary=*/false, "OctoMap (.ot)");
    std::unique_ptr<octomap::AbstractOcTree> abstract(octomap::AbstractOcTree::read(in));
    if (!abstract) throw InputError(path, 0, "malformed OctoMap (.ot)");
    auto* tree = dynamic_cast<octomap::OcTree*>(abstract.get());
    if (tree == nullptr) {
      throw InputError(
          path, 0,
          "OctoMap file holds a " + EchoValue(abstract->getTreeType()) + ", expected an OcTree");
    }
    CheckOctoMapComplete(path, in, declared, tree->size(), "OctoMap (.ot)");
    abstract.release();
    return std::unique_ptr<octomap::OcTree>(tree);
  }
  throw InputError(path, 1, "not an OctoMap file (header '" + EchoValue(header, 40) + "')");
}

}  // namespace dygslam
