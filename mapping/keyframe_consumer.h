// The one consumer of the SLAM's keyframe stream: each KeyframeData is a new keyframe,
// a pose correction (local BA, loop closing) or the removal of a culled keyframe, and this class
// applies it to the OctoMapBuilder it owns. KeyframeMapper (direct runs, `dygslam map`: a worker
// thread behind a queue) and the mapper component (MapperCore: Keyframe messages) feed it; neither
// dispatches on the kind itself.
//
//   KeyframeConsumer consumer(camera, options);
//   system.SetKeyframeCallback([&](const KeyframeData& k) { consumer.Apply(k); });  // one thread
//   consumer.builder().WriteBinary("map.bt");
//
// Not thread-safe (like the builder): one owner thread.
#pragma once

#include <cstddef>
#include <optional>

#include "core/base/camera.h"
#include "core/base/types.h"
#include "mapping/octomap_builder.h"

namespace dygslam {

enum class KeyframeChange {
  kNew,         // a new keyframe: its static part is inserted
  kPoseUpdate,  // KeyframeData::pose_update_only: the keyframe moved
  kRemoved,     // KeyframeData::removed: the keyframe was culled
};
KeyframeChange ChangeOf(const KeyframeData& keyframe);
const char* ToString(KeyframeChange change);

struct KeyframeApplied {
  KeyframeChange change = KeyframeChange::kNew;
  // false: a pose update or removal of a keyframe the map does not hold (ignored).
  bool applied = false;
};

class KeyframeConsumer {
 public:
  // Throws InvalidOptions if camera or options fail Check().
  KeyframeConsumer(const PinholeCamera& camera, const OctoMapOptions& options);

  // new -> OctoMapBuilder::Insert, pose update -> UpdatePoses, removed -> Remove. Throws what
  // the builder throws (InputError naming the keyframe and the field).
  // A new keyframe's static cloud may come extracted (ExtractStaticCloud with the builder's camera
  // and options; the keyframe's images are then not read).
  KeyframeApplied Apply(const KeyframeData& keyframe, std::optional<StaticCloud> cloud = {});

  // Applied keyframes of each kind (updates and removals of unknown keyframes not counted).
  size_t num_inserted() const { return num_inserted_; }
  size_t num_pose_updates() const { return num_pose_updates_; }
  size_t num_removed() const { return num_removed_; }

  OctoMapBuilder& builder() { return builder_; }
  const OctoMapBuilder& builder() const { return builder_; }

 private:
  OctoMapBuilder builder_;
  size_t num_inserted_ = 0, num_pose_updates_ = 0, num_removed_ = 0;
};

}  // namespace dygslam
