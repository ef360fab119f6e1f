#include "components/mapper_core.h"

#include <sstream>
#include <utility>

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

void MapperCore::Process(const KeyframeData& keyframe, const PinholeCamera& camera,
                         std::optional<StaticCloud> cloud) {
  if (consumer_ == nullptr) {
    if (ChangeOf(keyframe) != KeyframeChange::kNew) return;  // nothing to correct or remove yet
    consumer_ = std::make_unique<KeyframeConsumer>(camera, options_.octomap);
    if (base_) consumer_->builder().SetBaseMap(*base_, options_.base_map_path);
  }
  const KeyframeApplied applied = consumer_->Apply(keyframe, std::move(cloud));
  if (applied.change == KeyframeChange::kNew && keyframe.stamp > newest_) newest_ = keyframe.stamp;
}

size_t MapperCore::num_keyframes() const {
  return consumer_ == nullptr ? 0 : consumer_->builder().KeyframeIds().size();
}

msg::MapUpdate MapperCore::MakeUpdate() {
  msg::MapUpdate m;
  OctoMapStats stats;
  if (consumer_) stats = consumer_->builder().Stats();
  const octomap::OcTree& tree = consumer_ ? consumer_->builder().tree() : *base_;
  if (!consumer_) {
    stats.num_leaves = tree.getNumLeafNodes();
    for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it)
      stats.num_occupied_leaves += tree.isNodeOccupied(*it);
  }
  std::ostringstream stream;
  WriteOctoMapBinaryStream(tree, stream);
  const std::string bytes = stream.str();
  m.header().stamp(TimeToMsg(newest_));
  m.header().frame_id("world");
  m.header().seq(num_inserted());
  m.resolution(tree.getResolution());
  m.num_keyframes(stats.num_keyframes);
  m.num_leaf_nodes(stats.num_leaves);
  m.num_occupied(stats.num_occupied_leaves);
  m.octree_bt().assign(bytes.begin(), bytes.end());
  return m;
}

void MapperCore::Write() {
  if (options_.map_path.empty()) return;
  if (consumer_ == nullptr) {
    if (base_) WriteOctoMapBinary(*base_, options_.map_path);  // localization: the loaded map
    return;
  }
  consumer_->builder().WriteBinary(options_.map_path);
}

void MapperCore::Finalize() {
  if (consumer_ != nullptr) consumer_->builder().Finalize();
}

bool MapperCore::WriteFull() {
  if (options_.full_map_path.empty()) return false;
  if (consumer_ != nullptr) {
    consumer_->builder().WriteFull(options_.full_map_path);
  } else if (base_) {
    WriteOctoMapFull(*base_, options_.full_map_path);  // localization: the loaded map
  } else {
    return false;
  }
  return true;
}

}  // namespace dygslam
