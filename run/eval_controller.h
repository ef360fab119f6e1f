// The trajectory evaluation behind `dygslam eval`: ATE and RPE of an estimate against a ground
// truth (core/eval/trajectory_eval.h, TUM benchmark conventions), the aligned estimate and the
// plot written as outputs, and the summary printed as text or JSON.
#pragma once

#include <cstddef>
#include <string>

#include "core/eval/trajectory_eval.h"

namespace dygslam {

struct EvalControllerOptions {
  std::string groundtruth;  // TUM trajectory files
  std::string estimate;
  // Ground-truth body-to-camera calibration: "bonn" (the dataset's marker-to-camera transform)
  // or "none" (ResolveGroundTruthCalibration turns "auto" into one of them).
  std::string calibration = "none";
  bool calibrated_ate = false;  // the calibration for the ATE too (else RPE only)
  AteOptions ate;
  RpeOptions rpe;
  std::string save_aligned;  // "" = not written
  std::string plot;          // "" = not drawn
  std::string plot_script;   // scripts/plot_trajectory.py
  // Throws InvalidOptions naming what is wrong (no file names, an unknown calibration).
  void Check() const;
};

// --gt-calibration: "bonn" or "none" as given; "auto" is "bonn" when a folder or file name on
// the ground truth's path (as given or resolved) contains "bonn". Throws InvalidOptions else.
std::string ResolveGroundTruthCalibration(const std::string& value, const std::string& gt_path);

struct EvalSummary {
  EvalControllerOptions options;
  size_t gt_poses = 0, est_poses = 0;
  AteResult ate;
  RpeResult rpe;
  bool plotted = false;  // the plot was drawn (python3 + matplotlib available)
};

class EvalController {
 public:
  explicit EvalController(EvalControllerOptions options);
  // Reads both trajectories (warnings on stderr), scores them, writes the outputs. Throws
  // InputError naming the file (no poses, errors that are no finite number, a failed plot).
  EvalSummary Run() const;

 private:
  EvalControllerOptions options_;
};

// Why the files of an evaluation may not be used or written, "" when they may (a usage error,
// before any work): the estimate is the ground truth, an output is an input or the other output,
// a file of a dataset, an image a dataset's lists name (also outside its folder), a plot path
// that is a folder or a user's file that is no PNG picture.
std::string FindEvalFileProblem(const EvalControllerOptions& options);

// The summary as one JSON object (one line), and as the text `dygslam eval` prints.
std::string EvalSummaryJson(const EvalSummary& summary);
std::string EvalSummaryText(const EvalSummary& summary);

}  // namespace dygslam
