// CPU per frame of the System, with and without the dataset's PNG decoding. Each run
// first decodes every frame once, each frame's images released before the next as a camera
// driver or the run's loader does (the player's work; its CPU time is measured alone), then
// decodes them again into memory (not measured: the first touch of the ~1.5 MB per frame that the
// benchmark holds at once is its own cost, not decoding's; it doubled the figure), then feeds the
// decoded frames to a new System as fast as it takes them (the robot case: a camera driver hands
// over raw images) and measures the CPU time of the whole process (user + sys, all threads:
// getrusage(RUSAGE_SELF)) from the first frame to the end of System::Shutdown (local mapping
// drained). The next frame's detection is prefetched as in `dygslam run --direct`.
//
//   cpu_per_frame_benchmark DATASET_DIR [--config FILE] [--filter MODE] [--runs N]
//                           [--deterministic]
//
// Prints per run: frames, decode CPU ms per frame, System CPU ms per frame, their sum, wall
// seconds of the feed, ATE RMSE (all frames) when the dataset has a ground truth, and the number
// of frames with a pose (the ATE is over these); then medians.
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "core/base/log.h"
#include "core/eval/trajectory_eval.h"
#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "core/system/system.h"
#include "run/run_settings.h"
#include "tests/support/benchmark_args.h"

namespace {
using namespace dygslam;

double ProcessCpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  auto seconds = [](const timeval& t) { return t.tv_sec + t.tv_usec * 1e-6; };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

struct DecodedFrame {
  cv::Mat rgb, depth;
  Timestamp stamp;
};

int Usage() {
  std::fprintf(stderr,
               "usage: cpu_per_frame_benchmark DATASET_DIR [--config FILE] [--filter MODE] "
               "[--runs N] [--deterministic]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  BenchmarkArgs args;
  args.filter = "full";
  if (!ParseBenchmarkArgs(argc, argv, /*allow_deterministic=*/true, &args)) return Usage();
  const std::string& dataset_dir = args.dataset_dir;
  const std::string& config = args.config;
  const std::string& filter = args.filter;
  const int runs = args.runs;
  const bool deterministic = args.deterministic;
  try {
    SetLogLevel(LogLevel::kWarning);
    RunSettingsRequest request;
    request.settings_path = config.empty() ? dataset_dir + "/camera.yaml" : config;
    request.filter = filter;
    request.deterministic = deterministic;
    SystemOptions options = LoadRunConfiguration(request).system;
    if (deterministic) MakeDeterministic(&options);
    const RgbdDataset dataset = RgbdDataset::Open(dataset_dir);
    std::vector<double> decode_ms, system_ms, total_ms, ate_m;
    std::printf(
        "| run | frames | decode CPU ms/frame | System CPU ms/frame | sum | feed wall s | ATE RMSE "
        "m | poses |\n");
    std::printf("|---|---|---|---|---|---|---|---|\n");
    for (int run = 0; run < runs; ++run) {
      const auto decode = [&](size_t index) {
        return DecodedFrame{dataset.LoadRgb(index, options.camera.width, options.camera.height),
                            dataset.LoadDepth(index, options.camera.width, options.camera.height),
                            dataset.frame(index).rgb_stamp};
      };
      const double decode_start = ProcessCpuSeconds();
      for (size_t k = 0; k < dataset.num_rgb_entries(); ++k) {
        if (const auto index = dataset.FrameForRgbEntry(k)) decode(*index);  // then released
      }
      const double decode_s = ProcessCpuSeconds() - decode_start;
      std::vector<DecodedFrame> frames;
      for (size_t k = 0; k < dataset.num_rgb_entries(); ++k) {
        if (const auto index = dataset.FrameForRgbEntry(k)) frames.push_back(decode(*index));
      }
      if (frames.empty()) throw InputError(dataset_dir + ": no frame with rgb and depth");

      System system(options);  // start-up (models, vocabulary) is not per-frame work
      const double feed_start = ProcessCpuSeconds();
      const auto wall_start = std::chrono::steady_clock::now();
      for (size_t k = 0; k < frames.size(); ++k) {
        if (k + 1 < frames.size())
          system.PrefetchDetections(frames[k + 1].rgb, frames[k + 1].stamp);
        system.FeedRgbdFrame(frames[k].rgb, frames[k].depth, frames[k].stamp);
      }
      system.Shutdown();
      const double feed_s = ProcessCpuSeconds() - feed_start;
      const double wall_s =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
      const double n = static_cast<double>(frames.size());
      decode_ms.push_back(decode_s * 1e3 / n);
      system_ms.push_back(feed_s * 1e3 / n);
      total_ms.push_back((decode_s + feed_s) * 1e3 / n);
      double ate = -1;
      const std::vector<StampedPose> trajectory = system.Trajectory();
      if (dataset.has_groundtruth()) {
        ate = ComputeAte(ReadTumTrajectory(dataset.groundtruth_path()), trajectory).error.rmse;
        ate_m.push_back(ate);
      }
      std::printf("| %d | %zu | %.1f | %.1f | %.1f | %.1f | %.4f | %zu/%zu |\n", run + 1,
                  frames.size(), decode_ms.back(), system_ms.back(), total_ms.back(), wall_s, ate,
                  trajectory.size(), frames.size());
      std::fflush(stdout);
    }
    std::printf("| median | | %.1f | %.1f | %.1f | | %.4f | |\n", Median(decode_ms),
                Median(system_ms), Median(total_ms), Median(ate_m));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "cpu_per_frame_benchmark: %s\n", e.what());
    return 1;
  }
  return 0;
}
