#include "components/dds/qos.h"

#include <algorithm>

namespace dygslam::dds {

using namespace eprosima::fastdds::dds;  // NOLINT

namespace {

struct Policy {
  bool reliable = true;
  bool transient_local = false;
  bool keep_all = false;
  int depth = 1;         // keep-last: history depth
  int max_samples = -1;  // keep-all: bound of the history (-1 = unbounded)
  // Payloads allocated per sample at their size and freed with it: a history that mixes large and
  // small samples (keyframes with images, pose updates) holds what it stores, not n x the largest.
  bool exact_size_payloads = false;
};

Policy PolicyFor(TopicKind kind) {
  switch (kind) {
    case TopicKind::kRgbdFrame:
      return {true, false, false, kFrameHistoryDepth};
    case TopicKind::kDetections:
      return {true, true, false, 32};
    case TopicKind::kCameraPose:
      return {true, true, false, 64};
    case TopicKind::kKeyframe:
      return {true, true, true, 0, kKeyframeHistoryDepth, true};
    case TopicKind::kMapUpdate:
      return {true, true, false, 1};
    case TopicKind::kGroundTruth:
      return {true, true, true, 0};
    case TopicKind::kTrajectory:
      return {true, true, false, 2};
    case TopicKind::kStreamStatus:
      return {true, true, false, 16};
  }
  return {};
}

template <class Qos>
void Apply(const Policy& p, Qos* qos) {
  qos->reliability().kind = p.reliable ? RELIABLE_RELIABILITY_QOS : BEST_EFFORT_RELIABILITY_QOS;
  qos->durability().kind =
      p.transient_local ? TRANSIENT_LOCAL_DURABILITY_QOS : VOLATILE_DURABILITY_QOS;
  if (p.keep_all) {
    qos->history().kind = KEEP_ALL_HISTORY_QOS;
  } else {
    qos->history().kind = KEEP_LAST_HISTORY_QOS;
    qos->history().depth = p.depth;
  }
  qos->resource_limits().max_samples = p.max_samples;
  qos->resource_limits().max_instances = 1;
  qos->resource_limits().max_samples_per_instance = p.max_samples;
  if (p.max_samples > 0) {
    qos->resource_limits().allocated_samples = std::min(p.max_samples, 8);
  }
  qos->endpoint().history_memory_policy =
      p.exact_size_payloads ? eprosima::fastrtps::rtps::DYNAMIC_RESERVE_MEMORY_MODE
                            : eprosima::fastrtps::rtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
}

}  // namespace

DataWriterQos WriterQos(TopicKind kind) {
  DataWriterQos qos = DATAWRITER_QOS_DEFAULT;
  Apply(PolicyFor(kind), &qos);
  // Frames: the writer never waits long for a slow reader (keep-last); bound the blocking time.
  qos.reliability().max_blocking_time = eprosima::fastrtps::Duration_t(1, 0);
  // Status: a component waits for its last status (DONE, FAILED) to be acknowledged before it
  // goes. Readers acknowledge in answer to the writer's heartbeat, by default every 3 s, so
  // each run's end waited for that heartbeat (2 s, then gave up) although every reader had the
  // sample. Status samples are few and small: a heartbeat every 50 ms costs nothing.
  if (kind == TopicKind::kStreamStatus) {
    qos.reliable_writer_qos().times.heartbeatPeriod =
        eprosima::fastrtps::Duration_t(0, kStatusHeartbeatNs);
  }
  return qos;
}

DataReaderQos ReaderQos(TopicKind kind) {
  DataReaderQos qos = DATAREADER_QOS_DEFAULT;
  Apply(PolicyFor(kind), &qos);
  return qos;
}

}  // namespace dygslam::dds
