// Thread-safe front of a KeyframeConsumer (mapping/keyframe_consumer.h) for a running SLAM: the
// keyframe callback (tracking thread for new keyframes, local-mapping thread for pose corrections
// and culled keyframes) hands each KeyframeData to Submit(), which deep-copies the images into a
// FIFO queue and returns; one worker thread applies the queue in submission order with the
// consumer it owns:
//   new keyframe        -> OctoMapBuilder::Insert (filter, downsample, ray-cast insertion)
//   pose_update_only    -> OctoMapBuilder::UpdatePoses (rebuild deferred until the map is read)
//   removed             -> OctoMapBuilder::Remove
// The map read after Flush() depends only on the order of submissions (the read rebuilds what
// pose corrections left stale, see max_rebuild_share), so a deterministic SLAM run gives the same
// map every time with max_rebuild_share = 0 (background rebuilds happen at times that depend on
// the machine; they change the final map only by corrections below the rebuild threshold).
//
//   KeyframeMapper mapper(camera, options);
//   system.SetKeyframeCallback([&mapper](const KeyframeData& k) { mapper.Submit(k); });
//   ...
//   mapper.Flush();                                   // queue applied
//   mapper.WithBuilder([](OctoMapBuilder& b) { b.WriteBinary("map.bt"); });
//
// A pose correction for a keyframe whose previous correction is still queued (with nothing else
// for that keyframe after it) replaces that correction's pose instead of queueing again.
// Nothing is dropped: when max_queue submissions are waiting, Submit() blocks (back-pressure on
// the SLAM) and counts it in MapperStats::num_blocked. An exception from the builder (bad
// keyframe data) is kept and rethrown by the next Flush()/WithBuilder(); Submit() never throws
// it, because it runs inside the SLAM's callback (possibly on the local-mapping thread).
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "mapping/keyframe_consumer.h"
#include "mapping/octomap_builder.h"

namespace dygslam {

struct KeyframeMapperOptions {
  size_t max_queue = 32;  // submissions waiting before Submit() blocks
  // Background rebuilds after pose corrections: when the queue is empty and a rebuild is pending,
  // the worker rebuilds if the time since the end of the last rebuild is at least
  // (duration of the last rebuild) / max_rebuild_share, i.e. at most this share of the worker's
  // time goes to rebuilds however big the map grows (a rebuild costs ~25 ms CPU per keyframe).
  // 0 = never in the background (the tree is rebuilt when read: WithBuilder -> tree() / Write*).
  double max_rebuild_share = 0.3;
  void Check() const;
};

struct MapperStats {
  size_t num_submitted = 0;
  size_t num_applied = 0;    // num_submitted - num_coalesced once flushed
  size_t num_coalesced = 0;  // pose corrections merged into one still queued for the keyframe
  size_t num_new_keyframes = 0;
  size_t num_pose_updates = 0;
  size_t num_removals = 0;
  size_t max_queue_depth = 0;
  size_t num_blocked = 0;  // Submit() calls that had to wait for space
  size_t num_background_rebuilds = 0;
  double background_rebuild_ms = 0;  // total wall time of background rebuilds
  double worker_busy_ms = 0;         // total time the worker spent applying submissions
  double median_latency_ms = 0;      // new keyframes: Submit() to inserted
  double max_latency_ms = 0;
};

class KeyframeMapper {
 public:
  KeyframeMapper(const PinholeCamera& camera, const OctoMapOptions& options,
                 const KeyframeMapperOptions& mapper_options = {});
  // Applies what is queued, then stops the worker.
  ~KeyframeMapper();
  KeyframeMapper(const KeyframeMapper&) = delete;
  KeyframeMapper& operator=(const KeyframeMapper&) = delete;

  // Thread-safe. Copies the keyframe (depth and mask cloned; the colour image, which the map
  // does not read, is not kept). Does not throw the worker's errors.
  void Submit(const KeyframeData& keyframe);
  // Blocks until everything submitted so far is applied (and a due background rebuild is done).
  void Flush();
  // Runs fn on the builder with the worker paused (the queue keeps filling meanwhile).
  void WithBuilder(const std::function<void(OctoMapBuilder&)>& fn);
  MapperStats Stats() const;

 private:
  struct Item {
    KeyframeData keyframe;
    std::chrono::steady_clock::time_point submitted;
  };
  void Run();
  void RethrowIfFailed();  // lock held
  // Worker, mutex_ not held: background rebuild if due; its wall ms, or -1 if none.
  double MaybeRebuild();

  KeyframeMapperOptions mapper_options_;
  KeyframeConsumer consumer_;  // touched by the worker, or by WithBuilder under builder_mutex_
  std::mutex builder_mutex_;

  mutable std::mutex mutex_;  // guards everything below
  std::condition_variable changed_;
  std::deque<Item> queue_;
  bool busy_ = false;  // worker is applying an item
  bool stop_ = false;
  std::exception_ptr error_;
  MapperStats stats_;
  std::vector<double> latencies_ms_;
  // Worker only.
  std::chrono::steady_clock::time_point last_rebuild_end_;
  double last_rebuild_ms_ = 0;
  std::thread worker_;
};

}  // namespace dygslam
