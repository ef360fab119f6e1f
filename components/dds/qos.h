// Topic names and per-topic QoS of the dygslam pipeline.
//
// | topic                  | type               | reliability | durability      | history      |
// |------------------------|--------------------|-------------|-----------------|--------------|
// | dygslam/rgbd_frame     | RgbdFrame          | reliable    | volatile        | keep-last 4  |
// | dygslam/detections     | Detections         | reliable    | transient-local | keep-last 32 |
// | dygslam/camera_pose    | CameraPose         | reliable    | transient-local | keep-last 64 |
// | dygslam/keyframe       | Keyframe           | reliable    | transient-local | keep-all 64  |
// | dygslam/map_update     | MapUpdate          | reliable    | transient-local | keep-last 1  |
// | dygslam/ground_truth   | GroundTruthPose    | reliable    | transient-local | keep-all     |
// | dygslam/trajectory     | Trajectory         | reliable    | transient-local | keep-last 2  |
// | dygslam/stream_status  | StreamStatus       | reliable    | transient-local | keep-last 16 |
//
// Why:
// - Frames are large (~1.5 MB at 640x480 RGB-D 16-bit). Reliable + keep-last with a small depth
//   means no loss under normal load, while a slow reader can never make the writer block for long
//   (keep-last replaces the oldest sample instead of waiting for acknowledgement); the player's
//   back-pressure window (< depth) keeps the reader from falling behind by more than the depth.
//   Best effort loses 20-30 % of large frames; reliable with Fast DDS defaults (512 KiB SHM
//   segment) stalls 0.1-1 s: hence the 16 MiB SHM segment + 4 MiB socket buffers in
//   participant.h.
// - Detections / poses are small: reliable keep-last with a depth that covers any realistic lag.
//   Poses double as the frame acknowledgement for the player's back-pressure. Transient-local:
//   discovery is pairwise, so a reader (recorder, slam) may be matched by its writer a few ms
//   after the first samples went out; the writer then delivers them from its history (frames.csv
//   and the deterministic pairing need every one).
// - Keyframes are reliable + transient-local keep-all bounded to kKeyframeHistoryDepth samples:
//   a mapper that starts late (or restarts) receives the newest kKeyframeHistoryDepth keyframe
//   messages (new keyframes with images, local-BA pose updates, removals), then everything after.
//   Unbounded, the writer kept every keyframe ever made (~2.5 MB each with colour, depth in metres
//   and mask) plus every pose update: `dygslam run` grew ~0.5 MB per frame. Keep-all
//   with a bound (not keep-last) so a live reader never loses a message: when the history is full
//   the writer drops the oldest sample only once every matched reader acknowledged it (waiting up
//   to max_blocking_time); slam sends from a thread of its own and retries a refused message
//   (components/sample_order.h), so a paused reader delays keyframe messages (until it
//   acknowledges, or its lease unmatches it) but neither loses them nor blocks tracking. Payloads are sized per sample (DYNAMIC_RESERVE), so the ~16 small pose
//   updates per new keyframe do not each pin a 2.5 MB buffer: ~10 MB typical, 64 x 2.5 MB at most.
// - The map update carries the whole octree: only the newest one matters (keep-last 1), and a
//   late viewer gets it (transient-local).
// - Ground truth, the final trajectory and stream status are small and must not be missed by a
//   late recorder: transient-local.
// DataWriters use PREALLOCATED_WITH_REALLOC memory (samples have unbounded sequences), except the
// keyframe writer (DYNAMIC_RESERVE, see above).
#pragma once

#include <cstdint>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>
#include <string>

namespace dygslam::dds {

namespace topics {
inline constexpr const char* kRgbdFrame = "dygslam/rgbd_frame";
inline constexpr const char* kDetections = "dygslam/detections";
inline constexpr const char* kCameraPose = "dygslam/camera_pose";
inline constexpr const char* kKeyframe = "dygslam/keyframe";
inline constexpr const char* kMapUpdate = "dygslam/map_update";
inline constexpr const char* kGroundTruth = "dygslam/ground_truth";
inline constexpr const char* kTrajectory = "dygslam/trajectory";
inline constexpr const char* kStreamStatus = "dygslam/stream_status";
}  // namespace topics

enum class TopicKind {
  kRgbdFrame,
  kDetections,
  kCameraPose,
  kKeyframe,
  kMapUpdate,
  kGroundTruth,
  kTrajectory,
  kStreamStatus,
};

// Depth of the frame topic's keep-last history (the player's back-pressure window must be
// smaller).
inline constexpr int kFrameHistoryDepth = 4;
// Bound of the keyframe topic's transient-local history (messages), see above.
inline constexpr int kKeyframeHistoryDepth = 64;
// Heartbeat period of the status writers (ns): how soon a reader acknowledges a status sample.
inline constexpr uint32_t kStatusHeartbeatNs = 50'000'000;

eprosima::fastdds::dds::DataWriterQos WriterQos(TopicKind kind);
eprosima::fastdds::dds::DataReaderQos ReaderQos(TopicKind kind);

}  // namespace dygslam::dds
