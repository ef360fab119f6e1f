#include "bridge/tests/interop_support.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <exception>
#include <filesystem>

#include "core/config/settings.h"
#include "core/eval/trajectory_eval.h"
#include "core/io/trajectory_io.h"
#include "run/settings_table.h"
#include "run/system_config.h"

namespace dygslam::testing {

std::string BonnSettingsPath() {
  return std::string(std::getenv("DYGSLAM_SOURCE_DIR")) + "/config/bonn.yaml";
}

DirectReference RunDirectReference(const std::string& dataset_dir, size_t frames) {
  SystemOptions options = SystemOptionsFromSettings(LoadSettings(BonnSettingsPath()));
  options.deterministic = true;
  DirectReference ref{options, RgbdDataset::Open(dataset_dir), {}, {}, 0};
  ref.groundtruth = ReadTumTrajectory(ref.dataset.groundtruth_path());
  for (size_t k = 0; k < frames; ++k) {
    if (auto i = ref.dataset.FrameForRgbEntry(k)) ref.indices.push_back(*i);
  }
  System system(options);
  for (size_t i : ref.indices) {
    system.FeedRgbdFrame(ref.dataset.LoadRgb(i), ref.dataset.LoadDepth(i),
                         ref.dataset.frame(i).rgb_stamp);
  }
  system.Shutdown();
  ref.ate = ComputeAte(ref.groundtruth, system.Trajectory()).error.rmse;
  return ref;
}

PipelineOptions BridgeFedPipeline(const SystemOptions& system, const std::string& output_dir,
                                  int domain) {
  PipelineOptions po;
  po.dataset_dir = "-";
  po.output_dir = output_dir;
  po.system = system;
  po.run_mapper = false;
  po.domain_id = domain;
  std::filesystem::create_directories(po.output_dir);
  return po;
}

namespace {
std::vector<std::string> BridgeFedComponents(const PipelineOptions& options) {
  std::vector<std::string> names = {"recorder", "slam"};
  if (options.NeedsDetectorComponent()) names.push_back("detector");
  return names;
}
}  // namespace

ComponentThreads::ComponentThreads(const PipelineOptions& options)
    : ComponentThreads(options, BridgeFedComponents(options)) {}

ComponentThreads::ComponentThreads(const PipelineOptions& options, std::vector<std::string> names)
    : options_(options), names_(std::move(names)) {
  for (const std::string& name : names_) {
    threads_[name] = std::thread([this, name] {
      int code = 1;
      try {
        code = RunComponent(name, options_, stop_);
      } catch (const std::exception& e) {
        ADD_FAILURE() << name << ": " << e.what();
      }
      std::lock_guard<std::mutex> lock(mutex_);
      codes_[name] = code;
    });
  }
}

ComponentThreads::~ComponentThreads() { StopAndJoin(); }

void ComponentThreads::Finish() {
  for (const char* name : {"slam", "recorder", "mapper"}) {
    const auto it = threads_.find(name);
    if (it != threads_.end() && it->second.joinable()) it->second.join();
  }
  StopAndJoin();
}

void ComponentThreads::StopAndJoin() {
  stop_->Request();
  for (auto& [name, thread] : threads_) {
    if (thread.joinable()) thread.join();
  }
}

int ComponentThreads::code(const std::string& name) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = codes_.find(name);
  return it == codes_.end() ? 1 : it->second;
}

PeerCamera PeerCameraOf(const PinholeCamera& c) {
  PeerCamera camera;
  camera.width = c.width;
  camera.height = c.height;
  camera.fx = c.fx;
  camera.fy = c.fy;
  camera.cx = c.cx;
  camera.cy = c.cy;
  camera.d = {c.k1, c.k2, c.p1, c.p2, c.k3};
  return camera;
}

LockstepResult PublishInLockstep(
    CyclonePeer& peer, const RgbdDataset& dataset, const std::vector<size_t>& indices,
    const PeerCamera& camera, const std::function<bool(int64_t stamp)>& answered,
    const std::function<void(int64_t stamp, std::chrono::steady_clock::time_point published)>&
        on_answer) {
  LockstepResult result;
  for (size_t i : indices) {
    const int64_t stamp = dataset.frame(i).rgb_stamp.nanoseconds();
    const cv::Mat rgb = dataset.LoadRgb(i);
    cv::Mat depth_mm;  // Bonn PNG: value / 5000 = m; ROS: millimetres
    dataset.LoadDepth(i).convertTo(depth_mm, CV_16UC1, 1000.0 / 5000.0);
    bool done = false;
    auto published = std::chrono::steady_clock::now();
    for (int attempt = 0; attempt < 5 && !done; ++attempt) {
      if (attempt > 0) ++result.republished;
      published = std::chrono::steady_clock::now();
      peer.PublishFrame(stamp, rgb, depth_mm, camera, "camera_color_optical_frame");
      done = WaitUntil([&] { return answered(stamp); }, std::chrono::seconds(3));
    }
    if (!done) {
      result.all_answered = false;
      result.unanswered_stamp = stamp;
      return result;
    }
    on_answer(stamp, published);
  }
  return result;
}

}  // namespace dygslam::testing
