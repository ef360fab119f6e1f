// Mapper component: Keyframe -> OctoMapBuilder -> map.bt (periodically and at the end, atomic)
// + MapUpdate (whole .bt stream + stats, transient-local keep-last 1).
// Keyframe messages are applied by a KeyframeConsumer (mapping/keyframe_consumer.h): a new
// keyframe is inserted, pose_update_only moves it, removed (culled by the SLAM) takes it out.
// Core: MapperCore (no DDS). Shell: RunMapper, ends after slam's COMPONENT_DONE and the keyframe
// queue is drained. On stop (SIGINT / SIGTERM) it keeps draining until slam's COMPONENT_DONE
// (slam publishes its last corrections when it stops) for at most flush_timeout_s while a
// keyframe writer is matched, then writes the map. If slam's keyframe writer goes away (slam
// ended or died) without a COMPONENT_DONE reaching the mapper, it ends after writer_gone_s.
#pragma once

#include <memory>
#include <string>

#include "components/component_common.h"
#include "components/convert.h"
#include "dygslam_msg/MapUpdate.h"
#include "mapping/keyframe_consumer.h"
#include "mapping/octomap_builder.h"

namespace dygslam {

namespace dds {
class Participant;
}

struct MapperOptions {
  OctoMapOptions octomap;
  std::string map_path = "map.bt";  // "" = do not write
  // An existing OctoMap (.ot, e.g. a previous run's) the map continues from (issue 15): keyframes
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
  // interval its cost grew with the map and the mapper took CPU from slam on 2 cores (issue 19).
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
  // keyframe, from its camera). Corrections and removals of unknown keyframes are ignored.
  void Process(const KeyframeData& keyframe, const PinholeCamera& camera);
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
  // The .ot (full_map_path), at the end of the run; false when there was nothing to write.
  bool WriteFull();

 private:
  MapperOptions options_;
  std::unique_ptr<KeyframeConsumer> consumer_;  // made on the first new keyframe
  std::unique_ptr<octomap::OcTree> base_;       // options.base_map_path, read at construction
  Timestamp newest_;
};

struct MapperStats {
  size_t keyframes_received = 0;
  size_t bad_samples = 0;
  // Keyframes from participants other than the run's slam (components/run_writers.h).
  size_t foreign_samples = 0;
  size_t updates_published = 0;
  size_t map_writes = 0;
};

MapperStats RunMapper(std::shared_ptr<dds::Participant> participant, const MapperOptions& options,
                      const StopFlagPtr& stop);

}  // namespace dygslam
