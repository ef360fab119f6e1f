// The dataset -> System loop, written once: `dygslam run --direct`, `dygslam map`,
// `dygslam bench` and the soak benchmark feed a System from a dataset folder through it.
//
//   DatasetRunOptions o;
//   o.first_entry = 0; o.last_entry = dataset.num_rgb_entries();
//   const StopFlag flag(StopFlag::Signals::kStop);  // core/base/stop_signal.h
//   o.stop = [&flag] { return flag.requested(); };
//   const DatasetRunSummary s = RunDatasetFrames(dataset, system, o,
//       [&](size_t entry, const FrameResult& r) { ... });   // after every fed frame
//
// rgb.txt entries [first_entry, last_entry) are fed in order; an entry without a depth partner is
// skipped (counted). With prefetch_detections, the next frame's image is loaded one frame ahead
// and its detection started (System::PrefetchDetections), so detection of frame t+1 overlaps the
// tracking of frame t. With `detections` (boxes from a file, e.g. `dygslam synth`'s ground truth)
// the detector does not run and nothing is prefetched.
//
// Images are decoded ahead on a loader thread (decode_ahead frames), so PNG decoding does not
// hold up tracking. With `rate` > 0 the frames arrive as from a camera: frame k becomes available
// (stamp_k - stamp_first) / rate after the start, and when the System takes the next frame it takes
// the newest one that has arrived; older ones that waited are dropped (a camera driver's queue of
// one). Each frame's latency (arrival to result) is measured.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <vector>

#include "core/base/timestamp.h"
#include "core/base/types.h"
#include "core/io/dataset.h"
#include "core/system/system.h"
#include "run/realtime_report.h"

namespace dygslam {

struct DatasetRunOptions {
  size_t first_entry = 0;  // rgb.txt entries [first_entry, last_entry)
  size_t last_entry = 0;
  // Expected image size (Camera.width x Camera.height); 0: not checked.
  int image_width = 0;
  int image_height = 0;
  // Load the next frame ahead and start its detection while this one is tracked.
  bool prefetch_detections = true;
  // Boxes per stamp instead of the System's detector (nullptr: the detector, if the filter mode
  // needs one). Must outlive the run.
  const std::map<Timestamp, std::vector<Detection>>* detections = nullptr;
  // Added to every frame's stamp (soak runs replay a sequence with stamps that keep increasing).
  int64_t stamp_offset_ns = 0;
  // > 0: play at this many times the dataset's frame rate, as a camera would (see above);
  // 0: as fast as the System takes the frames.
  double rate = 0;
  // Frames decoded ahead on the loader thread (>= 1).
  int decode_ahead = 4;
  // Polled before every frame; true ends the run (interrupted).
  std::function<bool()> stop;
  void Check() const;
};

struct DatasetRunSummary {
  size_t processed = 0;      // frames fed to the System
  size_t lost = 0;           // of them, TrackingState::kLost
  size_t skipped = 0;        // entries without a depth partner (of those reached)
  bool interrupted = false;  // `stop` ended the run before last_entry
  double seconds = 0;        // wall time of the loop
  // rate > 0: frames replaced by a newer one before the System took them, and per processed frame
  // its stamp and the time from its arrival to its result.
  size_t dropped = 0;
  std::vector<ResultLatency> latencies;
};

// Called after each fed frame with its rgb.txt entry and the System's result.
using FrameCallback = std::function<void(size_t entry, const FrameResult& result)>;

// Feeds the frames; throws what the dataset throws for a bad image (InputError naming it), after
// feeding every frame before it, and InvalidOptions for a range outside the dataset. Does not
// shut the System down (the caller can still write what the frames before the error gave).
DatasetRunSummary RunDatasetFrames(const RgbdDataset& dataset, System& system,
                                   const DatasetRunOptions& options,
                                   const FrameCallback& on_frame = {});

// The boxes a dataset ships (generated sequences: DIR/detections.txt), read when the filter mode
// needs detections and the file exists; else an empty map and *found = false.
std::map<Timestamp, std::vector<Detection>> ShippedDetections(const RgbdDataset& dataset,
                                                              const SystemOptions& options,
                                                              bool* found);

}  // namespace dygslam
