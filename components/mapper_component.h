// Mapper component: Keyframe -> OctoMapBuilder -> map.bt (periodically and at the end, atomic)
// + MapUpdate (whole .bt stream + stats, transient-local keep-last 1).
// Keyframe messages are applied by a KeyframeConsumer (mapping/keyframe_consumer.h): a new
// keyframe is inserted, pose_update_only moves it, removed (culled by the SLAM) takes it out.
// Core: MapperCore (components/mapper_core.h, no DDS). Shell: RunMapper, ends after slam's
// COMPONENT_DONE and the keyframe queue is drained. On stop (SIGINT / SIGTERM) it keeps draining
// until slam's COMPONENT_DONE (slam publishes its last corrections when it stops) for at most
// flush_timeout_s while a keyframe writer is matched, then writes the map. If slam's keyframe
// writer goes away (slam ended or died) without a COMPONENT_DONE reaching the mapper, it ends after
// writer_gone_s.
#pragma once

#include <cstddef>
#include <memory>

#include "components/component_common.h"
#include "components/mapper_core.h"

namespace dygslam {

namespace dds {
class Participant;
}

struct MapperStats {
  size_t keyframes_received = 0;
  size_t bad_samples = 0;
  // Keyframes from participants other than the run's slam (components/run_writers.h).
  size_t foreign_samples = 0;
  size_t updates_published = 0;
  size_t map_writes = 0;
  // slam's keyframe writer left without the end of its run reaching the mapper (this process
  // paused or starved while slam finished, slam killed): the map may lack its last keyframes.
  bool input_cut_short = false;
  // Keyframe messages of slam that never arrived (gaps in its writer's sequence: they left slam's
  // bounded history while this mapper was paused or unreachable for longer than the DDS lease):
  // the map lacks them, the input is cut short as well.
  size_t keyframe_messages_missed = 0;
};

MapperStats RunMapper(std::shared_ptr<dds::Participant> participant, const MapperOptions& options,
                      const StopFlagPtr& stop);

}  // namespace dygslam
