// What the bridge's interop tests share (interop_test.cc on loopback, interop_lan_test.cc on a
// LAN-like namespace): the reference run of the System on the first Bonn frames, and the
// pipeline's consumers (slam, recorder, the detector if the filter needs it) on threads of the
// test, fed by the bridge instead of the player.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "bridge/tests/cyclone_peer.h"
#include "components/pipeline.h"
#include "core/base/stop_signal.h"
#include "core/base/types.h"
#include "core/io/dataset.h"
#include "core/system/system.h"

namespace dygslam::testing {

// $DYGSLAM_SOURCE_DIR/config/bonn.yaml.
std::string BonnSettingsPath();

template <class Pred>
bool WaitUntil(Pred pred, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!pred()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return true;
}

// rgb.txt entries [0, frames) of a dataset fed straight to the System (bonn.yaml,
// --deterministic): what a run through the bridge is compared with.
struct DirectReference {
  SystemOptions options;
  RgbdDataset dataset;
  std::vector<StampedPose> groundtruth;
  std::vector<size_t> indices;  // frames() indices of the entries with a depth partner
  double ate = 0;               // ATE RMSE of the direct trajectory (m)
};
DirectReference RunDirectReference(const std::string& dataset_dir, size_t frames);

// slam + recorder (+ detector) with `system`, no mapper, frames from outside (dataset "-"),
// outputs in output_dir, on `domain`.
PipelineOptions BridgeFedPipeline(const SystemOptions& system, const std::string& output_dir,
                                  int domain);

// The consumers of BridgeFedPipeline, each RunComponent on its own thread. The destructor stops
// and joins them (also on a failed ASSERT's early return).
class ComponentThreads {
 public:
  explicit ComponentThreads(const PipelineOptions& options);
  // Exactly the components `names` (e.g. with "mapper" for a player-fed pipeline).
  ComponentThreads(const PipelineOptions& options, std::vector<std::string> names);
  ~ComponentThreads();
  ComponentThreads(const ComponentThreads&) = delete;
  ComponentThreads& operator=(const ComponentThreads&) = delete;
  // Waits until slam, recorder and the mapper (if started) end (after END_OF_STREAM), then stops
  // the rest.
  void Finish();
  // Exit code of a finished component (1 if it threw or has not finished).
  int code(const std::string& name) const;
  // The components started ("recorder", "slam"[, "detector"]).
  const std::vector<std::string>& names() const { return names_; }

 private:
  void StopAndJoin();
  PipelineOptions options_;
  std::vector<std::string> names_;
  std::shared_ptr<StopFlag> stop_ = std::make_shared<StopFlag>();
  std::map<std::string, std::thread> threads_;
  mutable std::mutex mutex_;
  std::map<std::string, int> codes_;
};

// The CameraInfo a ROS camera driver would publish for `camera` (plumb_bob k1 k2 p1 p2 k3).
PeerCamera PeerCameraOf(const PinholeCamera& camera);

// A camera driver in lockstep with slam: the Cyclone `peer` publishes the dataset frames
// `indices` (colour, depth in millimetres as ROS drivers send it, CameraInfo), the next one once
// `answered(stamp)` is true for the previous one (as the player's back-pressure); a frame not
// answered within 3 s is published again (best-effort images get lost), at most 5 times.
// `on_answer(stamp, published)` runs after each answered frame (published: its last publication).
struct LockstepResult {
  bool all_answered = true;
  int64_t unanswered_stamp = 0;  // the first frame slam never answered
  size_t republished = 0;
};
LockstepResult PublishInLockstep(
    CyclonePeer& peer, const RgbdDataset& dataset, const std::vector<size_t>& indices,
    const PeerCamera& camera, const std::function<bool(int64_t stamp)>& answered,
    const std::function<void(int64_t stamp, std::chrono::steady_clock::time_point published)>&
        on_answer);

}  // namespace dygslam::testing
