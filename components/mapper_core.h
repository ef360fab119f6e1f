// MapperCore: the mapper component's work without DDS. Keyframe messages' content (new /
// pose update / removed) -> KeyframeConsumer (mapping/keyframe_consumer.h) -> OctoMapBuilder; the
// map as a MapUpdate message (binary .bt stream) and as files (map.bt atomically, the .ot at the
// end). Optionally continues an existing OctoMap (base_map_path). The shell (mapper_component.h)
// reads keyframes, decides when to publish and writes the status.
#pragma once

#include <octomap/OcTree.h>

#include <cstddef>
#include <memory>
#include <optional>
#include <string>

#include "core/base/camera.h"
#include "core/base/timestamp.h"
#include "core/base/types.h"
#include "dygslam_msg/MapUpdate.h"
#include "mapping/keyframe_consumer.h"
#include "mapping/octomap_builder.h"

namespace dygslam {

struct MapperOptions {
  OctoMapOptions octomap;
  std::string map_path = "map.bt";  // "" = do not write
  // An existing OctoMap (.ot, e.g. a previous run's) the map continues from: keyframes
  // are inserted on top of it; without keyframes (localization) it is the map. "": none.
  std::string base_map_path;
  // At the end of the run, also the OctoMap with probabilities (.ot): what base_map_path of a
  // later run continues (`dygslam run --save-map` sets DIR/map.ot). "" = not written.
  std::string full_map_path;
  // Write map.bt + publish MapUpdate every this many inserted keyframes (0 = only at the end)...
  int update_every_keyframes = 5;
  // ... but at most this share of the wall time: after an update that took d seconds the next
  // one waits until d / max_update_share have passed. An update reads the tree, i.e. rebuilds it
  // after local-BA pose corrections (~25 ms CPU per stored keyframe), so with a fixed keyframe
  // interval its cost grew with the map and the mapper took CPU from slam on 2 cores.
  // Same idea as KeyframeMapperOptions::max_rebuild_share of the direct mode. 1 = no limit.
  double max_update_share = 0.2;
  // After stop: longest wait for slam's last keyframe messages (seconds).
  double flush_timeout_s = 5.0;
  // Keyframe writer matched before and gone for this long, no COMPONENT_DONE: the run is over
  // (slam's DONE can be missed when it exits before the mapper's status reader matched). A slam
  // restarted within this time is simply followed.
  double writer_gone_s = 10.0;
  void Check() const;
};

class MapperCore {
 public:
  explicit MapperCore(const MapperOptions& options);
  // Applies a keyframe message (KeyframeConsumer::Apply; the consumer is made on the first new
  // keyframe, from its camera). Corrections and removals of unknown keyframes are ignored. A new
  // keyframe's static cloud may come extracted (ExtractStaticCloud with the first keyframe's
  // camera and options.octomap; its images are then not read).
  void Process(const KeyframeData& keyframe, const PinholeCamera& camera,
               std::optional<StaticCloud> cloud = {});
  bool has_map() const { return consumer_ != nullptr || base_ != nullptr; }
  // Keyframes currently in the map (inserted minus removed).
  size_t num_keyframes() const;
  size_t num_inserted() const { return consumer_ ? consumer_->num_inserted() : 0; }
  size_t num_pose_updates() const { return consumer_ ? consumer_->num_pose_updates() : 0; }
  size_t num_removed() const { return consumer_ ? consumer_->num_removed() : 0; }
  // Whole map as a MapUpdate (binary .bt stream). Requires has_map().
  msg::MapUpdate MakeUpdate();
  // Atomic .bt write (no-op without map or path).
  void Write();
  // At the end of the run: the map of the keyframes' final poses (OctoMapBuilder::Finalize), so
  // the last map.bt and MapUpdate do not depend on when the updates during the run happened.
  void Finalize();
  // The .ot (full_map_path), at the end of the run; false when there was nothing to write.
  bool WriteFull();

 private:
  MapperOptions options_;
  std::unique_ptr<KeyframeConsumer> consumer_;  // made on the first new keyframe
  std::unique_ptr<octomap::OcTree> base_;       // options.base_map_path, read at construction
  Timestamp newest_;
};

}  // namespace dygslam
