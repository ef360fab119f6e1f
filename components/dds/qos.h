// Topic names and per-topic QoS of the dygslam pipeline.
//
// | topic                  | type               | reliability | durability      | history      |
// |------------------------|--------------------|-------------|-----------------|--------------|
// | dygslam/rgbd_frame     | RgbdFrame          | reliable    | volatile        | keep-last 4  |
// | dygslam/detections     | Detections         | reliable    | transient-local | keep-last 32 |
// | dygslam/camera_pose    | CameraPose         | reliable    | transient-local | keep-last 64 |
// | dygslam/keyframe       | Keyframe           | reliable    | transient-local | keep-all     |
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
// - Keyframes are reliable + transient-local keep-all: a mapper that starts late (or restarts)
//   receives the whole keyframe history (memory grows with the number of keyframes, ~2.4 MB each).
// - The map update carries the whole octree: only the newest one matters (keep-last 1), and a
//   late viewer gets it (transient-local).
// - Ground truth, the final trajectory and stream status are small and must not be missed by a
//   late recorder: transient-local.
// All DataWriters use PREALLOCATED_WITH_REALLOC memory (samples have unbounded sequences).
#pragma once

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

eprosima::fastdds::dds::DataWriterQos WriterQos(TopicKind kind);
eprosima::fastdds::dds::DataReaderQos ReaderQos(TopicKind kind);

}  // namespace dygslam::dds
