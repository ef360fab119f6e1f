#include "run/eval_controller.h"

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <sstream>
#include <utility>
#include <vector>

#include "core/base/child_process.h"
#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/base/json.h"
#include "core/io/dataset.h"
#include "core/io/file_util.h"
#include "core/io/trajectory_io.h"

namespace dygslam {
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

// Writes the per-pair data and runs the plot script. Returns true when the PNG was written;
// prints why not otherwise.
bool Plot(const std::string& png, const std::string& script, const std::string& title,
          const AteResult& ate) {
  const fs::path out_dir =
      fs::path(png).parent_path().empty() ? fs::path(".") : fs::path(png).parent_path();
  std::error_code ec;
  if (!fs::is_directory(out_dir, ec)) {
    throw InputError(png, 0,
                     "cannot write plot: directory " + out_dir.string() + " does not exist");
  }
  if (!fs::is_regular_file(script, ec)) {
    std::cerr << "dygslam eval: plot skipped: " << script
              << " not found (set DYGSLAM_SCRIPTS_DIR)\n";
    return false;
  }
  // The pairs and the drawing go into a folder of this process's own (mkdtemp: a new name, mode
  // 0700), where no one else can plant a file or link; the picture is then written like every
  // output (a temporary name renamed over FILE, into the folder pinned when eval started).
  std::string private_dir = (fs::temp_directory_path() / "dygslam_plot_XXXXXX").string();
  if (::mkdtemp(private_dir.data()) == nullptr)
    throw InputError(png, 0,
                     std::string("cannot make a folder for the plot: ") + std::strerror(errno));
  const fs::path data = fs::path(private_dir) / "ate_pairs.txt";
  const fs::path drawn = fs::path(private_dir) / "plot.png";
  WriteFileAtomically(data.string(), AtePairsText(ate));
  const int code = RunProgram(
      {"python3", script, "--data", data.string(), "--out", drawn.string(), "--title", title});
  std::string bytes;
  if (code == 0) {
    std::ifstream in(drawn, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  fs::remove_all(private_dir, ec);
  if (code == 0) {
    if (bytes.empty()) throw InputError(png, 0, "plot failed: " + script + " wrote nothing");
    WriteFileAtomically(png, bytes);
    return true;
  }
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

// Finite but huge coordinates (1e300) overflow the squared errors: no number to report. Throws
// naming the file with the larger coordinates.
void CheckFinite(const EvalControllerOptions& o, const std::vector<StampedPose>& gt,
                 const std::vector<StampedPose>& est, const AteResult& ate, const RpeResult& rpe) {
  const bool rpe_finite =
      rpe.num_pairs == 0 || (std::isfinite(rpe.trans_rmse) && std::isfinite(rpe.rot_rmse));
  if (std::isfinite(ate.error.rmse) && std::isfinite(ate.error.max) && rpe_finite) return;
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
  throw InputError(est_largest >= gt_largest ? o.estimate : o.groundtruth, 0, why);
}

}  // namespace

void EvalControllerOptions::Check() const {
  if (groundtruth.empty() || estimate.empty())
    throw InvalidOptions("eval: a ground truth and an estimate are needed");
  if (calibration != "bonn" && calibration != "none")
    throw InvalidOptions("eval: calibration '" + EchoValue(calibration) +
                         "': expected bonn or none");
  if (!plot.empty() && plot_script.empty())
    throw InvalidOptions("eval: a plot needs the plot script");
}

std::string ResolveGroundTruthCalibration(const std::string& value, const std::string& gt_path) {
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

std::string FindEvalFileProblem(const EvalControllerOptions& o) {
  // One file given twice scores nothing (ATE 0 would read as a perfect run).
  if (SameFile(o.groundtruth, o.estimate))
    return "ESTIMATE '" + EchoValue(o.estimate) + "' is GROUNDTRUTH '" + EchoValue(o.groundtruth) +
           "': the same file; give the trajectory to score (e.g. out/trajectory.txt)";
  std::vector<NamedPath> outputs;
  if (!o.save_aligned.empty()) outputs.push_back({"--save-aligned", o.save_aligned});
  if (!o.plot.empty()) outputs.push_back({"--plot", o.plot});
  // The outputs never replace an input or each other.
  if (const std::string clash =
          FindOutputClash({{"GROUNDTRUTH", o.groundtruth}, {"ESTIMATE", o.estimate}}, outputs);
      !clash.empty())
    return clash;
  // Never a file of a dataset (its images, lists or ground truth).
  for (const NamedPath& output : outputs) {
    if (const std::string dataset = DatasetFolderOf(output.path); !dataset.empty())
      return output.role + " '" + EchoValue(output.path) + "' is a file of the dataset " +
             EchoValue(dataset) +
             " (it holds rgb.txt and depth.txt, or associations.txt): choose another path";
  }
  // Nor an image of the dataset the trajectories belong to, wherever its lists put it (an
  // absolute path outside the dataset folder).
  for (const std::string& input : {o.groundtruth, o.estimate}) {
    const std::string dataset_dir = DatasetFolderOf(input);
    if (dataset_dir.empty() || outputs.empty()) continue;
    std::string clash;
    try {
      clash = FindOutputOnDatasetImage(RgbdDataset::Open(dataset_dir, DatasetOptions()),
                                       dataset_dir, outputs);
    } catch (const std::exception&) {
      continue;  // lists eval does not need: nothing to protect that it could name
    }
    if (!clash.empty()) return clash;
  }
  // A plot replaces an earlier picture, never another kind of file given by mistake.
  if (!o.plot.empty()) {
    if (const std::string foreign =
            FindForeignFileAtOutput({"--plot", o.plot}, "\x89PNG\r\n\x1a\n", "a PNG picture");
        !foreign.empty())
      return foreign;
  }
  return "";
}

EvalController::EvalController(EvalControllerOptions options) : options_(std::move(options)) {
  options_.Check();
}

EvalSummary EvalController::Run() const {
  const EvalControllerOptions& o = options_;
  const std::vector<StampedPose> gt = ReadTumTrajectory(o.groundtruth);
  const std::vector<StampedPose> est = ReadTumTrajectory(o.estimate);
  for (const auto& [path, poses] : {std::pair{o.groundtruth, &gt}, std::pair{o.estimate, &est}}) {
    if (const std::string note = ImplausibleGroundTruthNote(path, *poses); !note.empty())
      std::fprintf(stderr, "dygslam eval: warning: %s\n", EchoValue(note, 600).c_str());
  }
  if (est.empty()) throw InputError(o.estimate, 0, "estimate has no poses");
  if (gt.empty()) throw InputError(o.groundtruth, 0, "ground truth has no poses");
  const std::vector<StampedPose> gt_camera =
      o.calibration == "bonn" ? MoveGroundTruthToCamera(gt, BonnMarkerFromCamera()) : gt;
  EvalSummary s;
  s.options = o;
  s.gt_poses = gt.size();
  s.est_poses = est.size();
  s.ate = ComputeAte(o.calibrated_ate ? gt_camera : gt, est, o.ate);
  s.rpe = ComputeRpe(gt_camera, est, o.rpe);
  CheckFinite(o, gt, est, s.ate, s.rpe);
  if (!o.save_aligned.empty()) WriteTumTrajectory(o.save_aligned, s.ate.aligned_estimate);
  if (!o.plot.empty()) {
    s.plotted = Plot(o.plot, o.plot_script,
                     fs::path(o.estimate).filename().string() + " vs " +
                         fs::path(o.groundtruth).filename().string(),
                     s.ate);
  }
  return s;
}

std::string EvalSummaryJson(const EvalSummary& s) {
  const EvalControllerOptions& o = s.options;
  const AteResult& ate = s.ate;
  const RpeResult& rpe = s.rpe;
  const double coverage = static_cast<double>(ate.num_pairs) / static_cast<double>(s.gt_poses);
  const bool has_rpe = rpe.num_pairs > 0;
  const auto rpe_value = [&](double v) { return has_rpe ? JsonNumber(v) : std::string("null"); };
  const Eigen::Quaterniond& q = ate.gt_from_est.rotation;
  const Eigen::Vector3d& t = ate.gt_from_est.translation;
  std::ostringstream j;
  j << "{\"groundtruth\": " << JsonString(o.groundtruth)
    << ", \"estimate\": " << JsonString(o.estimate) << ", \"gt_poses\": " << s.gt_poses
    << ", \"est_poses\": " << s.est_poses << ", \"pairs\": " << ate.num_pairs
    << ", \"gt_coverage\": " << JsonNumber(coverage)
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
    << ", \"gt_calibration\": " << JsonString(o.calibration)
    << ", \"ate_calibrated\": " << (o.calibrated_ate ? "true" : "false")
    << ", \"gt_from_est\": {\"tx\": " << JsonNumber(t.x()) << ", \"ty\": " << JsonNumber(t.y())
    << ", \"tz\": " << JsonNumber(t.z()) << ", \"qx\": " << JsonNumber(q.x())
    << ", \"qy\": " << JsonNumber(q.y()) << ", \"qz\": " << JsonNumber(q.z())
    << ", \"qw\": " << JsonNumber(q.w()) << "}"
    << ", \"plot\": " << (s.plotted ? JsonString(o.plot) : std::string("null")) << "}\n";
  return j.str();
}

std::string EvalSummaryText(const EvalSummary& s) {
  const EvalControllerOptions& o = s.options;
  const AteResult& ate = s.ate;
  const RpeResult& rpe = s.rpe;
  const double coverage = static_cast<double>(ate.num_pairs) / static_cast<double>(s.gt_poses);
  std::ostringstream out;
  out << "ground truth: " << o.groundtruth << " (" << s.gt_poses << " poses)\n"
      << "estimate:     " << o.estimate << " (" << s.est_poses << " poses)\n";
  if (o.calibration == "bonn") {
    out << "ground truth is the Bonn marker body: moved to the camera with the dataset's "
           "marker-to-camera calibration for "
        << (o.calibrated_ate ? "ATE and RPE" : "RPE (ATE as given)") << "\n";
  }
  out << Printf(
      "ATE  pairs %zu (%.1f%% of ground truth), rigid SE(3) alignment, metres\n"
      "     rmse %.6f  mean %.6f  median %.6f  sd %.6f  min %.6f  max %.6f\n",
      ate.num_pairs, 100.0 * coverage, ate.error.rmse, ate.error.mean, ate.error.median,
      ate.error.sd, ate.error.min, ate.error.max);
  if (rpe.num_pairs > 0) {
    out << Printf(
        "RPE  pairs %zu, delta %g s\n"
        "     translation (m per %g s)   rmse %.6f  mean %.6f  median %.6f\n"
        "     rotation (deg per %g s)    rmse %.6f  mean %.6f  median %.6f\n",
        rpe.num_pairs, rpe.delta, rpe.delta, rpe.trans_rmse, rpe.trans_mean, rpe.trans_median,
        rpe.delta, rpe.rot_rmse, rpe.rot_mean, rpe.rot_median);
  } else {
    out << "RPE  n/a (estimate shorter than the " << rpe.delta << " s interval)\n";
  }
  if (s.plotted) out << "plot: " << o.plot << "\n";
  return out.str();
}

}  // namespace dygslam
