// dygslam eval GROUNDTRUTH ESTIMATE [--json] [--plot FILE.png]: ATE / RPE with the TUM benchmark
// conventions (core/eval/trajectory_eval.h).
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "apps/command.h"
#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/io/file_util.h"
#include "run/eval_controller.h"

namespace dygslam::cli {
namespace {
namespace fs = std::filesystem;

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
  const std::string calibration = ResolveGroundTruthCalibration(p.Get("gt-calibration"), gt_path);
  if (p.Flag("calibrated-ate") && calibration == "none")
    return p.UsageError(
        "--calibrated-ate needs a ground-truth calibration (--gt-calibration bonn)");
  EvalControllerOptions o;
  o.groundtruth = gt_path;
  o.estimate = est_path;
  o.calibration = calibration;
  o.calibrated_ate = p.Flag("calibrated-ate");
  o.ate = ate_options;
  o.rpe = rpe_options;
  o.save_aligned = p.Has("save-aligned") ? p.Get("save-aligned") : "";
  o.plot = p.Has("plot") ? p.Get("plot") : "";
  o.plot_script = ScriptsDir() + "/plot_trajectory.py";
  if (const std::string problem = FindEvalFileProblem(o); !problem.empty())
    return p.UsageError(problem);
  if (!o.save_aligned.empty()) {
    const std::string foreign =
        FindForeignFileAtTrajectoryOutput({"--save-aligned", o.save_aligned});
    if (!foreign.empty()) return p.UsageError(foreign);
  }
  if (p.Has("plot")) {
    std::error_code ec;
    const std::string& png = o.plot;
    if (png.empty() || fs::is_directory(png, ec) || fs::path(png).filename().empty())
      return p.UsageError("--plot '" + png + "' is a folder or empty: give a FILE.png");
  }
  // The folders the files go into are the ones there now, even if replaced while eval runs.
  for (const std::string& output : {o.save_aligned, o.plot})
    if (!output.empty()) PinFolderOfOutput(output);
  const EvalSummary summary = EvalController(o).Run();
  std::cout << (p.Flag("json") ? EvalSummaryJson(summary) : EvalSummaryText(summary));
  return 0;
}

const CommandRegistrar kRegistrar({"eval", "evaluate a trajectory against ground truth (ATE/RPE)",
                                   RunEval});

}  // namespace
}  // namespace dygslam::cli
