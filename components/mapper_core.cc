#include "components/mapper_core.h"

#include <sstream>

#include "components/convert.h"
#include "core/base/error.h"

namespace dygslam {

void MapperOptions::Check() const {
  octomap.Check();
  DYGSLAM_CHECK_OPTION(update_every_keyframes >= 0, "mapper.update_every_keyframes");
  DYGSLAM_CHECK_OPTION(max_update_share > 0 && max_update_share <= 1, "mapper.max_update_share");
  DYGSLAM_CHECK_OPTION(flush_timeout_s >= 0, "mapper.flush_timeout_s");
  DYGSLAM_CHECK_OPTION(writer_gone_s > 0, "mapper.writer_gone_s");
}

MapperCore::MapperCore(const MapperOptions& options) : options_(options) {
  options_.Check();
  if (!options_.base_map_path.empty()) base_ = ReadOctoMap(options_.base_map_path);
}

void MapperCore::Process(const KeyframeData& keyframe, const PinholeCamera& camera) {
  if (keyframe.removed) {
    if (builder_ != nullptr && builder_->Remove(keyframe.id)) ++num_removed_;
    return;
  }
  if (keyframe.pose_update_only) {
    if (builder_ != nullptr &&
        builder_->UpdatePoses({{keyframe.id, keyframe.world_from_cam}}) > 0) {
      ++num_pose_updates_;
    }
    return;
  }
  if (builder_ == nullptr) {
    builder_ = std::make_unique<OctoMapBuilder>(camera, options_.octomap);
    if (base_) builder_->SetBaseMap(*base_, options_.base_map_path);
  }
  builder_->Insert(keyframe);
  ++num_inserted_;
  if (keyframe.stamp > newest_) newest_ = keyframe.stamp;
}

size_t MapperCore::num_keyframes() const {
  return builder_ == nullptr ? 0 : builder_->KeyframeIds().size();
}

msg::MapUpdate MapperCore::MakeUpdate() {
  msg::MapUpdate m;
  OctoMapStats stats;
  if (builder_) stats = builder_->Stats();
  const octomap::OcTree& tree = builder_ ? builder_->tree() : *base_;
  if (!builder_) {
    stats.num_leaves = tree.getNumLeafNodes();
    for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it)
      stats.num_occupied_leaves += tree.isNodeOccupied(*it);
  }
  std::ostringstream stream;
  tree.writeBinaryConst(stream);
  const std::string bytes = stream.str();
  m.header().stamp(TimeToMsg(newest_));
  m.header().frame_id("world");
  m.header().seq(num_inserted_);
  m.resolution(tree.getResolution());
  m.num_keyframes(stats.num_keyframes);
  m.num_leaf_nodes(stats.num_leaves);
  m.num_occupied(stats.num_occupied_leaves);
  m.octree_bt().assign(bytes.begin(), bytes.end());
  return m;
}

void MapperCore::Write() {
  if (options_.map_path.empty()) return;
  if (builder_ == nullptr) {
    if (base_) WriteOctoMapBinary(*base_, options_.map_path);  // localization: the loaded map
    return;
  }
  builder_->WriteBinary(options_.map_path);
}

bool MapperCore::WriteFull() {
  if (options_.full_map_path.empty()) return false;
  if (builder_ != nullptr) {
    builder_->WriteFull(options_.full_map_path);
  } else if (base_) {
    WriteOctoMapFull(*base_, options_.full_map_path);  // localization: the loaded map
  } else {
    return false;
  }
  return true;
}

}  // namespace dygslam
