// Frame times while a global bundle adjustment runs (the global BA after a loop must not
// stall tracking). Runs a dataset through the System with real threading (tracking on this
// thread; local mapping, loop closing and the global BA on theirs) and splits the frames into
// those whose processing overlapped a global BA window (LoopClosingStats::global_ba_windows_s) and
// the others; prints count, median, p90, p99 and max of the per-frame wall time for each.
//
//   global_ba_benchmark DATASET_DIR [--config FILE] [--filter MODE] [--runs N]
//
// With a groundtruth.txt in the dataset it also prints each run's ATE RMSE (final trajectory).
// The dataset should contain a loop that is closed (e.g. `dygslam synth ... --loop-path ...
// --loop-inward`, docs/evaluation.md). The frames are fed as fast as they are processed (no
// real-time pacing), so a stall would show as frames longer than the global BA.
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
#include "run/dataset_runner.h"
#include "run/run_settings.h"
#include "tests/support/benchmark_args.h"

namespace {
using namespace dygslam;

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(p * (v.size() - 1) + 0.5));
  return v[k];
}

void PrintRow(const char* name, const std::vector<double>& t) {
  if (t.empty()) {
    std::printf("| %s | 0 | - | - | - | - |\n", name);
    return;
  }
  std::printf("| %s | %zu | %.1f | %.1f | %.1f | %.1f |\n", name, t.size(), Percentile(t, 0.5),
              Percentile(t, 0.9), Percentile(t, 0.99), *std::max_element(t.begin(), t.end()));
}

int Usage() {
  std::fprintf(
      stderr,
      "usage: global_ba_benchmark DATASET_DIR [--config FILE] [--filter MODE] [--runs N]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  BenchmarkArgs args;
  args.filter = "none";
  if (!ParseBenchmarkArgs(argc, argv, /*allow_deterministic=*/false, &args)) return Usage();
  const std::string& dataset_dir = args.dataset_dir;
  const std::string& config = args.config;
  const std::string& filter = args.filter;
  const int runs = args.runs;
  try {
    SetLogLevel(LogLevel::kWarning);
    RunSettingsRequest request;
    request.settings_path = config.empty() ? dataset_dir + "/camera.yaml" : config;
    request.filter = filter;
    SystemOptions options = LoadRunConfiguration(request).system;
    options.deterministic = false;
    options.loop_closing.enabled = true;
    const RgbdDataset dataset = RgbdDataset::Open(dataset_dir);
    bool shipped = false;
    const auto boxes = ShippedDetections(dataset, options, &shipped);
    std::vector<double> during_all, outside_all;
    for (int run = 0; run < runs; ++run) {
      System system(options);
      struct Timed {
        double start_s, end_s, ms;
      };
      std::vector<Timed> frames;
      DatasetRunOptions o;
      o.last_entry = dataset.num_rgb_entries();
      o.image_width = options.camera.width;
      o.image_height = options.camera.height;
      if (shipped) o.detections = &boxes;
      RunDatasetFrames(dataset, system, o, [&](size_t, const FrameResult& r) {
        const double end =
            std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
                .count();
        frames.push_back({end - r.times.total_ms / 1000.0, end, r.times.total_ms});
      });
      system.Shutdown();
      const LoopClosingStats stats = system.LoopClosingStatistics();
      std::vector<double> during, outside;
      for (const Timed& f : frames) {
        bool overlaps = false;
        for (const auto& [s, e] : stats.global_ba_windows_s)
          overlaps = overlaps || (f.start_s < e && f.end_s > s);
        (overlaps ? during : outside).push_back(f.ms);
      }
      std::printf(
          "run %d: %zu frames, %d loops closed, %zu global BAs (%d written back, %d "
          "discarded):",
          run + 1, frames.size(), stats.loops_closed, stats.global_ba_windows_s.size(),
          stats.global_ba_runs, stats.global_ba_discarded);
      for (const auto& [s, e] : stats.global_ba_windows_s) std::printf(" %.0f ms", (e - s) * 1e3);
      if (dataset.has_groundtruth()) {
        const AteResult ate =
            ComputeAte(ReadTumTrajectory(dataset.groundtruth_path()), system.Trajectory());
        std::printf("; ATE RMSE %.4f m over %zu poses", ate.error.rmse, ate.num_pairs);
      }
      for (const auto& [frame, loop_frame] : stats.loop_frames)
        std::printf("; loop: frame %lld with frame %lld", static_cast<long long>(frame),
                    static_cast<long long>(loop_frame));
      std::printf("\n");
      PrintRow("frames during a global BA", during);
      PrintRow("other frames", outside);
      during_all.insert(during_all.end(), during.begin(), during.end());
      outside_all.insert(outside_all.end(), outside.begin(), outside.end());
    }
    std::printf("all runs (frame wall ms: frames, median, p90, p99, max):\n");
    PrintRow("frames during a global BA", during_all);
    PrintRow("other frames", outside_all);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "global_ba_benchmark: %s\n", e.what());
    return 1;
  }
  return 0;
}
