#include "mapping/keyframe_consumer.h"

#include <utility>

namespace dygslam {

KeyframeChange ChangeOf(const KeyframeData& keyframe) {
  if (keyframe.removed) return KeyframeChange::kRemoved;
  if (keyframe.pose_update_only) return KeyframeChange::kPoseUpdate;
  return KeyframeChange::kNew;
}

const char* ToString(KeyframeChange change) {
  switch (change) {
    case KeyframeChange::kNew:
      return "new";
    case KeyframeChange::kPoseUpdate:
      return "pose update";
    case KeyframeChange::kRemoved:
      return "removed";
  }
  return "unknown";
}

KeyframeConsumer::KeyframeConsumer(const PinholeCamera& camera, const OctoMapOptions& options)
    : builder_(camera, options) {}

KeyframeApplied KeyframeConsumer::Apply(const KeyframeData& keyframe,
                                        std::optional<StaticCloud> cloud) {
  KeyframeApplied result;
  result.change = ChangeOf(keyframe);
  switch (result.change) {
    case KeyframeChange::kRemoved:
      result.applied = builder_.Remove(keyframe.id);
      num_removed_ += result.applied;
      break;
    case KeyframeChange::kPoseUpdate:
      result.applied = builder_.UpdatePoses({{keyframe.id, keyframe.world_from_cam}}) > 0;
      num_pose_updates_ += result.applied;
      break;
    case KeyframeChange::kNew:
      if (cloud) {
        builder_.Insert(keyframe, std::move(*cloud));
      } else {
        builder_.Insert(keyframe);
      }
      result.applied = true;
      ++num_inserted_;
      break;
  }
  return result;
}

}  // namespace dygslam
