// dygslam eval GROUNDTRUTH ESTIMATE [--json] [--plot FILE.png]: ATE / RPE with the TUM benchmark
// conventions (core/eval/trajectory_eval.h).
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "apps/command.h"
#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/base/json.h"
#include "core/eval/trajectory_eval.h"
#include "core/io/dataset.h"
#include "core/io/file_util.h"
#include "core/io/trajectory_io.h"

namespace dygslam::cli {
namespace {
namespace fs = std::filesystem;

// printf into a string of any length: a huge finite error (coordinates of 1e150) prints all its
// digits instead of a line cut at a fixed buffer.
__attribute__((format(printf, 1, 2))) std::string Printf(const char* format, ...) {
  va_list args;
  va_start(args, format);
  va_list again;
  va_copy(again, args);
  const int n = std::vsnprintf(nullptr, 0, format, args);
  va_end(args);
  std::string text(n > 0 ? static_cast<size_t>(n) : 0, '\0');
  if (n > 0) std::vsnprintf(text.data(), text.size() + 1, format, again);
  va_end(again);
  return text;
}

// --OPTION as seconds; `positive`: above 0. A malformed or out-of-range value is a usage error
// naming the option (InvalidOptions "--OPTION: ...": exit 2).
double ParseSeconds(const ArgParser& p, const std::string& option, bool positive) {
  const std::string text = p.Get(option);
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(v) || (positive && !(v > 0))) {
    throw InvalidOptions("--" + option + ": expected " +
                         (positive ? "seconds above 0" : "seconds") + ", got '" + EchoValue(text) +
                         "'");
  }
  return v;
}

// Writes the per-pair data and runs scripts/plot_trajectory.py. Returns true when the PNG was
// written; prints why not otherwise.
bool Plot(const std::string& png, const std::string& title, const AteResult& ate) {
  const fs::path out_dir =
      fs::path(png).parent_path().empty() ? fs::path(".") : fs::path(png).parent_path();
  std::error_code ec;
  if (!fs::is_directory(out_dir, ec)) {
    throw InputError(png, 0,
                     "cannot write plot: directory " + out_dir.string() + " does not exist");
  }
  const std::string script = ScriptsDir() + "/plot_trajectory.py";
  if (!fs::is_regular_file(script, ec)) {
    std::cerr << "dygslam eval: plot skipped: " << script
              << " not found (set DYGSLAM_SCRIPTS_DIR)\n";
    return false;
  }
  const fs::path data =
      fs::temp_directory_path() / ("dygslam_plot_" + std::to_string(::getpid()) + ".txt");
  WriteFileAtomically(data.string(), AtePairsText(ate));
  // Drawn into a private file, then written like every output (a temporary name renamed over
  // FILE, into the folder pinned when eval started).
  const fs::path drawn =
      fs::temp_directory_path() / ("dygslam_plot_" + std::to_string(::getpid()) + ".png");
  const std::string cmd = "python3 " + ShellQuote(script) + " --data " + ShellQuote(data.string()) +
                          " --out " + ShellQuote(drawn.string()) + " --title " + ShellQuote(title);
  const int status = std::system(cmd.c_str());
  fs::remove(data, ec);
  const int code = (status != -1 && WIFEXITED(status)) ? WEXITSTATUS(status) : -1;
  if (code == 0) {
    std::ifstream in(drawn, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    fs::remove(drawn, ec);
    if (bytes.empty()) throw InputError(png, 0, "plot failed: " + script + " wrote nothing");
    WriteFileAtomically(png, bytes);
    return true;
  }
  fs::remove(drawn, ec);
  if (code == 3) {
    std::cerr << "dygslam eval: plot skipped: python3-matplotlib is not installed "
                 "(apt-get install python3-matplotlib)\n";
  } else if (code == 127) {
    std::cerr << "dygslam eval: plot skipped: python3 not found\n";
  } else {
    // A plot that was asked for and could not be drawn is an error (exit 1), not a note.
    throw InputError(png, 0, "plot failed (" + script + " exit code " + std::to_string(code) + ")");
  }
  return false;
}

// --gt-calibration: "bonn" or "none"; "auto" is "bonn" when a folder or file name on the ground
// truth's path (as given or resolved) contains "bonn" (rgbd_bonn_crowd, bonn_crowd_part).
std::string GroundTruthCalibration(const std::string& value, const std::string& gt_path) {
  if (value == "bonn" || value == "none") return value;
  if (value != "auto")
    throw InvalidOptions("--gt-calibration: expected auto, bonn or none, got '" + EchoValue(value) +
                         "'");
  std::error_code ec;
  for (const fs::path& path : {fs::path(gt_path), fs::weakly_canonical(gt_path, ec)}) {
    for (const fs::path& part : path) {
      std::string name = part.string();
      std::transform(name.begin(), name.end(), name.begin(),
                     [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
      if (name.find("bonn") != std::string::npos) return "bonn";
    }
  }
  return "none";
}

int RunEval(const std::vector<std::string>& args) {
  ArgParser p(
      "eval", "GROUNDTRUTH ESTIMATE [--json] [--plot FILE.png]",
      "Absolute trajectory error (ATE: timestamp association within 0.02 s, rigid SE(3)\n"
      "alignment of the estimate onto the ground truth, no scale) and relative pose error\n"
      "(RPE over 1 s), with the conventions of the TUM RGB-D benchmark tools. Both files are\n"
      "TUM trajectories: 't tx ty tz qx qy qz qw' (world_from_cam).\n"
      "The Bonn RGB-D Dynamic dataset's ground truth is the pose of a motion-capture marker body,\n"
      "not of the camera: RPE moves it to the camera with the dataset's published "
      "marker-to-camera\n"
      "calibration (--gt-calibration; without it RPE would measure the marker-to-camera "
      "rotation).\n"
      "ATE uses the ground truth as given (as published tables do) unless --calibrated-ate.");
  p.AddPositional("GROUNDTRUTH", "ground-truth trajectory (e.g. DATASET/groundtruth.txt)");
  p.AddPositional("ESTIMATE", "estimated trajectory (e.g. out/trajectory.txt)");
  p.AddFlag("json", "print one JSON object instead of text");
  p.AddOption("plot", "FILE.png",
              "draw ground truth vs aligned estimate (top view) and ATE over time");
  p.AddOption("max-diff", "SECONDS", "maximum timestamp difference for association", "0.02");
  p.AddOption("offset", "SECONDS", "time offset added to the estimate stamps", "0");
  p.AddOption("delta", "SECONDS", "RPE interval", "1");
  p.AddOption("save-aligned", "FILE", "write the aligned estimate as a TUM trajectory");
  p.AddOption("gt-calibration", "auto|bonn|none",
              "ground-truth body-to-camera calibration for RPE; auto: bonn when the ground truth's "
              "path names a Bonn sequence",
              "auto");
  p.AddFlag("calibrated-ate", "apply the ground-truth calibration to the ATE too");
  if (!p.Parse(args)) return p.exit_code();

  // The options first: a usage error is found before the files are read.
  AteOptions ate_options;
  ate_options.max_time_difference = ParseSeconds(p, "max-diff", /*positive=*/true);
  ate_options.offset = ParseSeconds(p, "offset", /*positive=*/false);
  RpeOptions rpe_options;
  rpe_options.delta = ParseSeconds(p, "delta", /*positive=*/true);
  rpe_options.offset = ate_options.offset;

  const std::string gt_path = p.Positional("GROUNDTRUTH");
  const std::string est_path = p.Positional("ESTIMATE");
  const std::string calibration = GroundTruthCalibration(p.Get("gt-calibration"), gt_path);
  if (p.Flag("calibrated-ate") && calibration == "none")
    return p.UsageError(
        "--calibrated-ate needs a ground-truth calibration (--gt-calibration bonn)");
  // One file given twice scores nothing (ATE 0 would read as a perfect run).
  if (SameFile(gt_path, est_path))
    return p.UsageError("ESTIMATE '" + EchoValue(est_path) + "' is GROUNDTRUTH '" +
                        EchoValue(gt_path) +
                        "': the same file; give the trajectory to score (e.g. out/trajectory.txt)");
  // The outputs never replace an input or each other (exit 2, before any work).
  {
    std::vector<NamedPath> outputs;
    for (const char* option : {"save-aligned", "plot"})
      if (p.Has(option)) outputs.push_back({std::string("--") + option, p.Get(option)});
    const std::string clash =
        FindOutputClash({{"GROUNDTRUTH", gt_path}, {"ESTIMATE", est_path}}, outputs);
    if (!clash.empty()) return p.UsageError(clash);
    // Never a file of a dataset (its images, lists or ground truth).
    for (const char* option : {"save-aligned", "plot"}) {
      if (!p.Has(option)) continue;
      if (const std::string dataset = DatasetFolderOf(p.Get(option)); !dataset.empty())
        return p.UsageError(
            std::string("--") + option + " '" + EchoValue(p.Get(option)) +
            "' is a file of the dataset " + EchoValue(dataset) +
            " (it holds rgb.txt and depth.txt, or associations.txt): choose another path");
    }
    // Nor an image of the dataset the trajectories belong to, wherever its lists put it (an
    // absolute path outside the dataset folder).
    for (const std::string& input : {gt_path, est_path}) {
      const std::string dataset_dir = DatasetFolderOf(input);
      if (dataset_dir.empty() || outputs.empty()) continue;
      std::string clash;
      try {
        clash = FindOutputOnDatasetImage(RgbdDataset::Open(dataset_dir, DatasetOptions()),
                                         dataset_dir, outputs);
      } catch (const std::exception&) {
        continue;  // lists eval does not need: nothing to protect that it could name
      }
      if (!clash.empty()) return p.UsageError(clash);
    }
    if (p.Has("save-aligned")) {
      const std::string foreign =
          FindForeignFileAtTrajectoryOutput({"--save-aligned", p.Get("save-aligned")});
      if (!foreign.empty()) return p.UsageError(foreign);
    }
    // A plot replaces an earlier picture, never another kind of file given by mistake.
    if (p.Has("plot")) {
      const std::string foreign =
          FindForeignFileAtOutput({"--plot", p.Get("plot")}, "\x89PNG\r\n\x1a\n", "a PNG picture");
      if (!foreign.empty()) return p.UsageError(foreign);
    }
    // The folders the files go into are the ones there now, even if replaced while eval runs.
    for (const char* option : {"save-aligned", "plot"})
      if (p.Has(option)) PinFolderOfOutput(p.Get(option));
  }
  if (p.Has("plot")) {
    std::error_code ec;
    const std::string png = p.Get("plot");
    if (png.empty() || fs::is_directory(png, ec) || fs::path(png).filename().empty())
      return p.UsageError("--plot '" + png + "' is a folder or empty: give a FILE.png");
  }
  const std::vector<StampedPose> gt = ReadTumTrajectory(gt_path);
  const std::vector<StampedPose> est = ReadTumTrajectory(est_path);
  for (const auto& [path, poses] : {std::pair{gt_path, &gt}, std::pair{est_path, &est}}) {
    if (const std::string note = ImplausibleGroundTruthNote(path, *poses); !note.empty())
      std::fprintf(stderr, "dygslam eval: warning: %s\n", EchoValue(note, 600).c_str());
  }
  if (est.empty()) throw InputError(est_path, 0, "estimate has no poses");
  if (gt.empty()) throw InputError(gt_path, 0, "ground truth has no poses");
  const std::vector<StampedPose> gt_camera =
      calibration == "bonn" ? MoveGroundTruthToCamera(gt, BonnMarkerFromCamera()) : gt;
  const AteResult ate = ComputeAte(p.Flag("calibrated-ate") ? gt_camera : gt, est, ate_options);
  const RpeResult rpe = ComputeRpe(gt_camera, est, rpe_options);

  // Finite but huge coordinates (1e300) overflow the squared errors: no number to report.
  const bool rpe_finite =
      rpe.num_pairs == 0 || (std::isfinite(rpe.trans_rmse) && std::isfinite(rpe.rot_rmse));
  if (!std::isfinite(ate.error.rmse) || !std::isfinite(ate.error.max) || !rpe_finite) {
    double gt_largest = 0, est_largest = 0;
    for (const StampedPose& s : gt)
      gt_largest = std::max(gt_largest, s.world_from_cam.translation.cwiseAbs().maxCoeff());
    for (const StampedPose& s : est)
      est_largest = std::max(est_largest, s.world_from_cam.translation.cwiseAbs().maxCoeff());
    char why[256];
    std::snprintf(why, sizeof(why),
                  "the error is not a finite number: coordinates too large (largest |coordinate| "
                  "%g in the ground truth, %g in the estimate)",
                  gt_largest, est_largest);
    throw InputError(est_largest >= gt_largest ? est_path : gt_path, 0, why);
  }

  if (p.Has("save-aligned")) WriteTumTrajectory(p.Get("save-aligned"), ate.aligned_estimate);
  bool plotted = false;
  if (p.Has("plot")) {
    plotted = Plot(
        p.Get("plot"),
        fs::path(est_path).filename().string() + " vs " + fs::path(gt_path).filename().string(),
        ate);
  }

  const double coverage = static_cast<double>(ate.num_pairs) / static_cast<double>(gt.size());
  if (p.Flag("json")) {
    const bool has_rpe = rpe.num_pairs > 0;
    const auto rpe_value = [&](double v) { return has_rpe ? JsonNumber(v) : std::string("null"); };
    const Eigen::Quaterniond& q = ate.gt_from_est.rotation;
    const Eigen::Vector3d& t = ate.gt_from_est.translation;
    std::ostringstream j;
    j << "{\"groundtruth\": " << JsonString(gt_path) << ", \"estimate\": " << JsonString(est_path)
      << ", \"gt_poses\": " << gt.size() << ", \"est_poses\": " << est.size()
      << ", \"pairs\": " << ate.num_pairs << ", \"gt_coverage\": " << JsonNumber(coverage)
      << ", \"ate_rmse\": " << JsonNumber(ate.error.rmse)
      << ", \"ate_mean\": " << JsonNumber(ate.error.mean)
      << ", \"ate_median\": " << JsonNumber(ate.error.median)
      << ", \"ate_sd\": " << JsonNumber(ate.error.sd)
      << ", \"ate_min\": " << JsonNumber(ate.error.min)
      << ", \"ate_max\": " << JsonNumber(ate.error.max)
      << ", \"rpe_delta\": " << JsonNumber(rpe.delta) << ", \"rpe_pairs\": " << rpe.num_pairs
      << ", \"rpe_trans_rmse\": " << rpe_value(rpe.trans_rmse)
      << ", \"rpe_trans_mean\": " << rpe_value(rpe.trans_mean)
      << ", \"rpe_trans_median\": " << rpe_value(rpe.trans_median)
      << ", \"rpe_rot_rmse\": " << rpe_value(rpe.rot_rmse)
      << ", \"rpe_rot_mean\": " << rpe_value(rpe.rot_mean)
      << ", \"rpe_rot_median\": " << rpe_value(rpe.rot_median)
      << ", \"gt_calibration\": " << JsonString(calibration)
      << ", \"ate_calibrated\": " << (p.Flag("calibrated-ate") ? "true" : "false")
      << ", \"gt_from_est\": {\"tx\": " << JsonNumber(t.x()) << ", \"ty\": " << JsonNumber(t.y())
      << ", \"tz\": " << JsonNumber(t.z()) << ", \"qx\": " << JsonNumber(q.x())
      << ", \"qy\": " << JsonNumber(q.y()) << ", \"qz\": " << JsonNumber(q.z())
      << ", \"qw\": " << JsonNumber(q.w()) << "}"
      << ", \"plot\": " << (plotted ? JsonString(p.Get("plot")) : std::string("null")) << "}\n";
    std::cout << j.str();
    return 0;
  }
  std::cout << "ground truth: " << gt_path << " (" << gt.size() << " poses)\n"
            << "estimate:     " << est_path << " (" << est.size() << " poses)\n";
  if (calibration == "bonn") {
    std::cout << "ground truth is the Bonn marker body: moved to the camera with the dataset's "
                 "marker-to-camera calibration for "
              << (p.Flag("calibrated-ate") ? "ATE and RPE" : "RPE (ATE as given)") << "\n";
  }
  std::cout << Printf(
      "ATE  pairs %zu (%.1f%% of ground truth), rigid SE(3) alignment, metres\n"
      "     rmse %.6f  mean %.6f  median %.6f  sd %.6f  min %.6f  max %.6f\n",
      ate.num_pairs, 100.0 * coverage, ate.error.rmse, ate.error.mean, ate.error.median,
      ate.error.sd, ate.error.min, ate.error.max);
  if (rpe.num_pairs > 0) {
    std::cout << Printf(
        "RPE  pairs %zu, delta %g s\n"
        "     translation (m per %g s)   rmse %.6f  mean %.6f  median %.6f\n"
        "     rotation (deg per %g s)    rmse %.6f  mean %.6f  median %.6f\n",
        rpe.num_pairs, rpe.delta, rpe.delta, rpe.trans_rmse, rpe.trans_mean, rpe.trans_median,
        rpe.delta, rpe.rot_rmse, rpe.rot_mean, rpe.rot_median);
  } else {
    std::cout << "RPE  n/a (estimate shorter than the " << rpe.delta << " s interval)\n";
  }
  if (plotted) std::cout << "plot: " << p.Get("plot") << "\n";
  return 0;
}

const CommandRegistrar kRegistrar({"eval", "evaluate a trajectory against ground truth (ATE/RPE)",
                                   RunEval});

}  // namespace
}  // namespace dygslam::cli
