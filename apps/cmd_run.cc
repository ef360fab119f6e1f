// dygslam run DATASET_DIR [--config FILE] [--filter none|boxes|geometry|full] [--frames FIRST:LAST]
//              [--out DIR] [--deterministic]
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "apps/command.h"
#include "core/base/error.h"
#include "core/base/log.h"
#include "core/config/settings.h"
#include "core/config/system_config.h"
#include "core/eval/trajectory_eval.h"
#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "core/system/system.h"

namespace dygslam::cli {
namespace {
namespace fs = std::filesystem;

// "FIRST:LAST" (either side may be empty) -> [first, last) of rgb.txt entries.
std::pair<size_t, size_t> ParseFrames(const std::string& text, size_t total) {
  const auto colon = text.find(':');
  if (colon == std::string::npos) throw InvalidOptions("--frames: expected FIRST:LAST, got '" + text + "'");
  auto parse = [&](const std::string& s, size_t def) -> size_t {
    if (s.empty()) return def;
    for (char c : s)
      if (c < '0' || c > '9') throw InvalidOptions("--frames: not a non-negative integer: '" + s + "'");
    return std::stoul(s);
  };
  const size_t first = parse(text.substr(0, colon), 0);
  const size_t last = std::min(parse(text.substr(colon + 1), total), total);
  if (first >= last) throw InvalidOptions("--frames: empty range '" + text + "'");
  return {first, last};
}

std::string DefaultConfig(const std::string& dataset_dir) {
  // camera.yaml inside the dataset (generated sequences) wins; else a preset by folder name.
  const fs::path own = fs::path(dataset_dir) / "camera.yaml";
  if (fs::exists(own)) return own.string();
  const std::string name = fs::path(dataset_dir).lexically_normal().filename().string();
  const fs::path presets = fs::path(ScriptsDir()).parent_path() / "config";
  std::string preset = "bonn.yaml";
  if (name.find("freiburg1") != std::string::npos) preset = "tum1.yaml";
  if (name.find("freiburg2") != std::string::npos) preset = "tum2.yaml";
  if (name.find("freiburg3") != std::string::npos) preset = "tum3.yaml";
  return (presets / preset).string();
}

int RunRun(const std::vector<std::string>& args) {
  ArgParser p("run", "DATASET_DIR [--config FILE] [--filter none|boxes|geometry|full] [--frames FIRST:LAST] [--out DIR] [--deterministic]",
              "Runs the SLAM on a TUM/Bonn dataset folder; writes DIR/trajectory.txt (TUM format, every tracked\n"
              "frame), DIR/keyframes.txt and DIR/frames.csv (state and stage times per frame).");
  p.AddPositional("DATASET_DIR", "folder with rgb.txt, depth.txt (groundtruth.txt optional)");
  p.AddOption("config", "FILE", "settings YAML (ORB-SLAM2 keys); default: DATASET_DIR/camera.yaml or a preset");
  p.AddOption("filter", "MODE", "dynamic filter: none | boxes | geometry | full", "full");
  p.AddOption("frames", "FIRST:LAST", "rgb.txt entries FIRST (inclusive, 0-based) to LAST (exclusive)");
  p.AddOption("out", "DIR", "output folder", "out/run");
  p.AddFlag("deterministic", "fixed seeds and synchronous local mapping: identical output run to run");
  p.AddFlag("quiet", "no progress line");
  if (!p.Parse(args)) return p.exit_code();

  const std::string dataset_dir = p.Positional("DATASET_DIR");
  const std::string config = p.Has("config") ? p.Get("config") : DefaultConfig(dataset_dir);
  const Settings settings = LoadSettings(config);
  SystemOptions options = SystemOptionsFromSettings(settings);
  options.filter_mode = ParseFilterMode(p.Get("filter"));
  options.deterministic = p.Flag("deterministic");

  const RgbdDataset dataset = RgbdDataset::Open(dataset_dir);
  auto [first, last] = p.Has("frames") ? ParseFrames(p.Get("frames"), dataset.num_rgb_entries())
                                       : std::pair<size_t, size_t>{0, dataset.num_rgb_entries()};
  const fs::path out = p.Get("out");
  fs::create_directories(out);

  System system(options);
  std::ofstream frames_csv(out / "frames.csv.tmp");
  frames_csv << "stamp,state,keyframe,features,dynamic,tracked,orb_ms,detection_ms,matching_ms,probability_ms,tracking_ms,total_ms\n";
  const bool progress = !p.Flag("quiet");
  size_t processed = 0, lost = 0, skipped = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (size_t k = first; k < last; ++k) {
    const auto index = dataset.FrameForRgbEntry(k);
    if (!index) {
      ++skipped;
      continue;
    }
    const cv::Mat rgb = dataset.LoadRgb(*index, options.camera.width, options.camera.height);
    const cv::Mat depth = dataset.LoadDepth(*index, options.camera.width, options.camera.height);
    const FrameResult r = system.FeedRgbdFrame(rgb, depth, dataset.frame(*index).rgb_stamp);
    ++processed;
    if (r.state == TrackingState::kLost) ++lost;
    char line[512];
    std::snprintf(line, sizeof(line), "%s,%s,%d,%d,%d,%d,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f\n", r.stamp.ToString().c_str(),
                  ToString(r.state), r.is_keyframe ? 1 : 0, r.num_features, r.num_dynamic, r.num_tracked,
                  r.times.orb_extraction_ms, r.times.detection_ms, r.times.matching_ms, r.times.probability_ms,
                  r.times.tracking_ms, r.times.total_ms);
    frames_csv << line;
    if (progress && (processed % 10 == 0 || k + 1 == last)) {
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::fprintf(stderr, "\r[run] frame %zu/%zu  %.1f fps  state=%s  lost=%zu   ", k + 1 - first, last - first,
                   processed / std::max(elapsed, 1e-9), ToString(r.state), lost);
      std::fflush(stderr);
    }
  }
  if (progress) std::fprintf(stderr, "\n");
  system.Shutdown();
  frames_csv.close();
  fs::rename(out / "frames.csv.tmp", out / "frames.csv");
  const auto trajectory = system.Trajectory();
  WriteTumTrajectory((out / "trajectory.txt").string(), trajectory);
  WriteTumTrajectory((out / "keyframes.txt").string(), system.KeyframeTrajectory());
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("frames: %zu processed, %zu tracked, %zu lost, %zu without depth partner; %.1f fps\n", processed,
              trajectory.size(), lost, skipped, processed / std::max(elapsed, 1e-9));
  std::printf("filter: %s%s\n", ToString(options.filter_mode), options.deterministic ? " (deterministic)" : "");
  if (dataset.has_groundtruth() && trajectory.size() >= 3) {
    const AteResult ate = ComputeAte(ReadTumTrajectory(dataset.groundtruth_path()), trajectory);
    std::printf("ATE RMSE %.4f m (mean %.4f, median %.4f, max %.4f; %zu pairs)\n", ate.error.rmse, ate.error.mean,
                ate.error.median, ate.error.max, ate.num_pairs);
  }
  std::printf("outputs: %s/{trajectory.txt,keyframes.txt,frames.csv}\n", out.string().c_str());
  return 0;
}

const CommandRegistrar kRegistrar({"run", "run the SLAM on a dataset folder", RunRun});

}  // namespace
}  // namespace dygslam::cli
