// Dataset player: a TUM / Bonn folder -> RgbdFrame samples (+ ground truth + end of stream).
//
// Core (no DDS): DatasetPlayer loads frame i (images + intrinsics) and the ground truth.
// Shell: PlayerComponent publishes frames either at the dataset rate (rate = 1: stamps replayed
// in real time; 2 = twice as fast) or as fast as they are consumed (rate = 0), always with
// back-pressure when window > 0: frame k is published only once slam has acknowledged (published
// the CameraPose of) frame k - window, so nothing is dropped by the keep-last frame topic
// (window must be < kFrameHistoryDepth). Then it publishes StreamStatus END_OF_STREAM
// (num_frames, header.seq = last seq) and keeps its writers alive until slam reports done (or
// stop is requested).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "components/component_common.h"
#include "components/convert.h"
#include "core/base/camera.h"
#include "core/io/dataset.h"
#include "run/realtime_report.h"

namespace dygslam {

namespace dds {
class Participant;
}

struct PlayerOptions {
  std::string dataset_dir;
  PinholeCamera camera;
  double depth_scale = 5000.0;  // DepthMapFactor
  // 1 = dataset rate, k = k times faster, 0 = as fast as consumed (back-pressure only).
  double rate = 0.0;
  // rgb.txt entries [first_entry, last_entry) (last_entry 0 = all), as `dygslam run --frames`;
  // entries without a depth partner are skipped.
  size_t first_entry = 0;
  size_t last_entry = 0;
  // Back-pressure window in frames (0 = none: publish at `rate` regardless of the consumer).
  int window = 3;
  // Longest wait for an acknowledgement before a frame is sent anyway (seconds).
  double ack_timeout_s = 30.0;
  // Wait for at least one frame reader before the first frame (seconds).
  double wait_for_readers_s = 10.0;
  int expected_readers = 1;
  // Components whose READY announcement (components/protocol.h) the player waits for before the
  // first frame (the pipeline lists the ones it runs), at most wait_for_components_s seconds.
  std::vector<ComponentKind> wait_for_components;
  double wait_for_components_s = 60.0;
  // After slam's end, wait for the DONE of the recorder and the mapper among wait_for_components
  // (they write the run's outputs) and say when one left without it or stopped early.
  bool watch_consumers = true;
  bool publish_ground_truth = true;
  // > 0: replay the range again and again until this much wall time has passed (soak runs); each
  // replay's stamps continue after the previous one's (+ 1 s), seq keeps counting.
  double loop_minutes = 0;
  void Check() const;
};

class DatasetPlayer {
 public:
  explicit DatasetPlayer(const PlayerOptions& options);
  size_t num_frames() const { return indices_.size(); }
  // Frame `i` of the played range (seq = i): BGR colour, 16UC1 depth, camera, stamps.
  RgbdFrameData Frame(size_t i) const;
  // Colour stamp of frame `i` (no image loaded).
  Timestamp Stamp(size_t i) const;
  // Ground truth within the played time span (empty if the dataset has none).
  std::vector<StampedPose> GroundTruth() const;

 private:
  PlayerOptions options_;
  RgbdDataset dataset_;
  std::vector<size_t> indices_;  // dataset frame index of each played frame
};

// Latency statistics in bounded memory (soak runs publish frames for hours): a uniform random
// sample of at most `capacity` values (reservoir sampling, fixed seed), exact while fewer values
// than that were added.
class LatencyReservoir {
 public:
  explicit LatencyReservoir(size_t capacity = 4096);
  void Add(double value);
  size_t count() const { return count_; }         // values added
  size_t size() const { return sample_.size(); }  // values kept (<= capacity)
  // q-quantile (0..1) of the kept values, as the element at index floor(q * size) of the sorted
  // sample (0 when empty).
  double Quantile(double q) const;

 private:
  size_t capacity_;
  size_t count_ = 0;
  std::vector<double> sample_;
  uint64_t state_ = 0x9e3779b97f4a7c15ULL;  // xorshift64* state
};

struct PlayerStats {
  size_t frames_published = 0;
  size_t ack_timeouts = 0;
  size_t ground_truth_published = 0;
  double seconds = 0;
  // Frame published -> its pose received back (the player reads the poses for back-pressure):
  // end-to-end latency through detector and slam, and the rate at which poses came back.
  size_t poses_timed = 0;
  double latency_median_ms = 0, latency_p95_ms = 0, latency_p99_ms = 0;
  double poses_per_second = 0;
  // Paced runs (rate > 0): poses that came more than kLateFramePeriods frame periods (at the
  // played rate) after their frame was published.
  size_t late = 0;
  // Each pose's frame stamp and latency in the order the poses came (at most kMaxLatencyRows).
  std::vector<ResultLatency> latencies;
  // Paced runs: the longest time without a pose while frames were published (a stall).
  double longest_gap_s = 0;
  // The consumers took another frame source's frames (it started first on the partition) and
  // none of this player's: it stopped publishing (the component then fails).
  bool refused = false;
  // slam left without announcing that it is done (killed), failed, or ended before the end of
  // the stream (stopped by a signal): the frames it did not process have no pose, the run is
  // incomplete.
  bool slam_left_early = false;
  // The run's recorder left without announcing that it is done (killed): the run's outputs are
  // not written, the run is incomplete.
  bool recorder_left_early = false;
  // Likewise the run's mapper (waited for, and READY): the map lacks what it had not written.
  bool mapper_left_early = false;
};

// Publishes the dataset; returns when slam reported done, or stop was requested.
PlayerStats RunPlayer(std::shared_ptr<dds::Participant> participant, const PlayerOptions& options,
                      const StopFlagPtr& stop);

}  // namespace dygslam
