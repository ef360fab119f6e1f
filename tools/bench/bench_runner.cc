#include "tools/bench/bench_runner.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "core/base/error.h"
#include "core/eval/trajectory_eval.h"
#include "core/io/detections_io.h"
#include "core/io/file_util.h"
#include "core/io/trajectory_io.h"
#include "run/dataset_runner.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

double SecondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void CheckRange(size_t first, size_t last) {
  if (first >= last)
    throw InvalidOptions("frame range: empty range [" + std::to_string(first) + ", " +
                         std::to_string(last) + ")");
}

}  // namespace

RunOutput RunSystemOnSequence(const RgbdDataset& dataset, const SystemOptions& options,
                              size_t first, size_t last, const RunProgress& progress) {
  last = std::min(last, dataset.num_rgb_entries());
  CheckRange(first, last);
  System system(options);
  RunOutput out;
  // A sequence that ships its own boxes (generated sequences: ground-truth detections.txt) is run
  // with those instead of the detector, so box/full configurations work without a model.
  bool use_file_detections = false;
  const auto file_detections = ShippedDetections(dataset, options, &use_file_detections);
  DatasetRunOptions run;
  run.first_entry = first;
  run.last_entry = last;
  run.image_width = options.camera.width;
  run.image_height = options.camera.height;
  if (use_file_detections) run.detections = &file_detections;
  const auto t0 = std::chrono::steady_clock::now();
  const DatasetRunSummary summary =
      RunDatasetFrames(dataset, system, run, [&](size_t k, const FrameResult& r) {
        out.rows.push_back(FrameRowFromResult(r));
        if (progress) progress(k + 1 - first, last - first);
      });
  out.frames = static_cast<int>(summary.processed);
  out.lost = static_cast<int>(summary.lost);
  system.Shutdown();
  out.loop_seconds = SecondsSince(t0);  // local mapping's last keyframes included
  out.trajectory = system.Trajectory();
  return out;
}

RunOutput RunOdometryOnSequence(const RgbdDataset& dataset, const PinholeCamera& camera,
                                double depth_map_factor, const RgbdOdometryOptions& options,
                                size_t first, size_t last, const RunProgress& progress) {
  last = std::min(last, dataset.num_rgb_entries());
  CheckRange(first, last);
  RgbdOdometryBaseline odometry(camera, depth_map_factor, options);
  RunOutput out;
  const auto t0 = std::chrono::steady_clock::now();
  for (size_t k = first; k < last; ++k) {
    const auto index = dataset.FrameForRgbEntry(k);
    if (!index) continue;
    const cv::Mat rgb = dataset.LoadRgb(*index, camera.width, camera.height);
    const cv::Mat depth = dataset.LoadDepth(*index, camera.width, camera.height);
    const OdometryStep step = odometry.Track(rgb, depth, dataset.frame(*index).rgb_stamp);
    ++out.frames;
    if (!step.ok) ++out.lost;
    FrameRow row;
    row.stamp = step.stamp;
    row.state = step.ok ? TrackingState::kOk : TrackingState::kLost;
    row.times.total_ms = step.time_ms;
    out.rows.push_back(row);
    if (progress) progress(k + 1 - first, last - first);
  }
  out.loop_seconds = SecondsSince(t0);
  out.trajectory = odometry.Trajectory();
  return out;
}

void WriteRunOutput(const std::string& directory, const RunOutput& output) {
  std::error_code ec;
  fs::create_directories(directory, ec);
  if (!fs::is_directory(directory)) throw InputError(directory, 0, "cannot create the run folder");
  RunOutputs outputs(directory, {"trajectory.txt", "frames.csv", "summary.txt"});
  RunRecord record;
  record.rows = output.rows;
  record.trajectory = output.trajectory;
  WriteRunRecord(outputs, record);
  std::ostringstream summary;
  summary << "frames " << output.frames << "\nlost " << output.lost << "\nloop_seconds "
          << output.loop_seconds << "\n";
  outputs.Write("summary.txt",
                [&] { WriteFileAtomically(outputs.PathOf("summary.txt"), summary.str()); });
  if (!outputs.failures().empty()) {
    const auto& [name, reason] = outputs.failures().front();
    throw InputError(outputs.PathOf(name), 0, "not written: " + reason);
  }
}

StageMeans MeanStageTimes(const std::vector<StageTimes>& times) {
  StageMeans m;
  if (times.empty()) return m;
  for (const StageTimes& t : times) {
    m.orb_ms +=
        t.orb_extraction_ms + t.top_up_ms;  // extraction, including the crowded-frame top-up
    m.detection_ms += t.detection_ms;
    m.detection_wait_ms += t.detection_wait_ms;
    m.matching_ms += t.matching_ms;
    m.probability_ms += t.probability_ms;
    m.tracking_ms += t.tracking_ms;
    m.local_mapping_ms += t.local_mapping_ms;
    m.total_ms += t.total_ms;
  }
  const double n = static_cast<double>(times.size());
  for (double* v : {&m.orb_ms, &m.detection_ms, &m.detection_wait_ms, &m.matching_ms,
                    &m.probability_ms, &m.tracking_ms, &m.local_mapping_ms, &m.total_ms})
    *v /= n;
  return m;
}

BenchRun ScoreRun(const std::string& directory, const std::vector<StampedPose>& groundtruth) {
  const fs::path dir(directory);
  BenchRun run;
  // summary.txt
  const std::string summary_path = (dir / "summary.txt").string();
  bool has_frames = false, has_lost = false, has_loop = false;
  for (const TextLine& line : ReadDataLines(summary_path)) {
    if (line.tokens.size() != 2)
      throw InputError(summary_path, line.line_number, "expected 'key value'");
    const std::string& key = line.tokens[0];
    char* end = nullptr;
    const double v = std::strtod(line.tokens[1].c_str(), &end);
    if (*end != '\0')
      throw InputError(summary_path, line.line_number, key + ": not a number: " + line.tokens[1]);
    if (key == "frames") run.frames = static_cast<int>(v), has_frames = true;
    if (key == "lost") run.lost = static_cast<int>(v), has_lost = true;
    if (key == "loop_seconds") run.loop_seconds = v, has_loop = true;
  }
  if (!has_frames || !has_lost || !has_loop)
    throw InputError(summary_path, 0, "missing key (frames, lost, loop_seconds)");
  run.fps = run.loop_seconds > 0 ? run.frames / run.loop_seconds : 0;
  // frames.csv
  const std::string frames_path = (dir / "frames.csv").string();
  std::vector<StageTimes> times;
  for (const FrameRow& row : ReadFramesCsv(frames_path)) times.push_back(row.times);
  run.stages = MeanStageTimes(times);
  {
    std::vector<double> totals;
    for (const StageTimes& t : times) totals.push_back(t.total_ms);
    run.stages.median_total_ms = Median(totals);
  }
  // trajectory.txt
  run.trajectory_path = (dir / "trajectory.txt").string();
  const std::vector<StampedPose> estimate = ReadTumTrajectory(run.trajectory_path);
  run.poses = static_cast<int>(estimate.size());
  try {
    const AteResult ate = ComputeAte(groundtruth, estimate);
    run.ate = ate.error;
    run.ate_pairs = static_cast<int>(ate.num_pairs);
  } catch (const InputError&) {
    // Fewer than 3 poses associated: the run failed; it has no ATE (NaN, left out of medians).
    const double nan = std::numeric_limits<double>::quiet_NaN();
    run.ate = ErrorStatistics{nan, nan, nan, nan, nan, nan};
    run.ate_pairs = 0;
  }
  return run;
}

}  // namespace dygslam
