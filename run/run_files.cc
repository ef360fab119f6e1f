#include "run/run_files.h"

#include <sys/stat.h>

#include <utility>

#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/io/trajectory_io.h"
#include "core/slam/map/map_file.h"
#include "run/realtime_report.h"
#include "run/run_outputs.h"

namespace dygslam {

std::vector<NamedPath> RunInputPaths(const RunFiles& files, const SystemOptions& system) {
  std::vector<NamedPath> inputs;
  if (!files.dataset_dir.empty() && files.dataset_dir != "-") {
    for (const char* name : {"rgb.txt", "depth.txt", "groundtruth.txt", "associations.txt"})
      inputs.push_back({std::string("the dataset's ") + name,
                        (std::filesystem::path(files.dataset_dir) / name).string()});
  }
  inputs.push_back(files.settings);
  for (const NamedPath& given : files.given)
    if (!given.path.empty()) inputs.push_back(given);
  inputs.push_back({"the vocabulary (LoopClosing.vocabulary)", system.loop_closing.vocabulary});
  inputs.push_back({"the detector's cfg", system.detector.cfg_path});
  inputs.push_back({"the detector's weights", system.detector.weights_path});
  inputs.push_back({"the detector's names", system.detector.names_path});
  return inputs;
}

std::vector<NamedPath> RunOutputPaths(const RunFiles& files) {
  std::vector<NamedPath> outputs;
  if (!files.save_map.empty()) outputs.push_back({"--save-map", files.save_map});
  if (!files.out_dir.empty()) {
    for (const std::string& name : files.out_names.empty() ? RunOutputNames() : files.out_names)
      outputs.push_back({"the output " + name, (files.out_dir / name).string()});
  }
  return outputs;
}

void CheckRunFiles(const RunFiles& files, const SystemOptions& system) {
  if (std::string clash = FindOutputClash(RunInputPaths(files, system), RunOutputPaths(files));
      !clash.empty())
    throw UsageError(clash);
}

void ClaimRunOutputs(const RunFiles& files, const RgbdDataset* dataset) {
  if (dataset != nullptr) {
    if (std::string clash =
            FindOutputOnDatasetImage(*dataset, files.dataset_dir, RunOutputPaths(files));
        !clash.empty())
      throw UsageError(clash);
  }
  if (!files.save_map.empty()) {
    if (std::string foreign = FindForeignFileAtOutput({"--save-map", files.save_map},
                                                      kMapFileSignature, "a dygslam map file");
        !foreign.empty())
      throw UsageError(foreign);
    PinFolderOfOutput(files.save_map);
  }
  if (files.out_dir.empty() || !files.claim_out_dir) return;
  if (std::string foreign = FindForeignFileInRunOutputs(files.out_dir); !foreign.empty())
    throw UsageError(foreign);
}

std::string FindForeignFileAtTrajectoryOutput(const NamedPath& output) {
  struct stat st {};
  if (::stat(output.path.c_str(), &st) != 0 || !S_ISREG(st.st_mode) || st.st_size == 0) return "";
  if (IsTumTrajectoryFile(output.path)) return "";
  return output.role + " '" + EchoValue(output.path) +
         "' exists and is not a TUM trajectory: it is not replaced; remove it first or choose "
         "another path";
}

std::string FindForeignFileInRunOutputs(const std::filesystem::path& out_dir) {
  // The first bytes of each output ("" for the TUM trajectories, read whole).
  const std::vector<std::pair<std::string, std::string>> kinds = {
      {"trajectory.txt", ""},
      {"trajectory_online.txt", ""},
      {"keyframes.txt", ""},
      {"groundtruth.txt", ""},
      {"frames.csv", "stamp,"},
      {"map.bt", "# Octomap OcTree binary file"},
      {"map.ot", "# Octomap OcTree file"},
      {kRealtimeReportFile, "rate "},
      {"eval.json", "{\"mode\": "},  // RunSummaryJson's first key (run/run_summary.h)
      // `dygslam map`'s pictures and reference map in the same folder.
      {"map_top.png", "\x89PNG\r\n\x1a\n"},
      {"map_slice.png", "\x89PNG\r\n\x1a\n"},
      {"ghosts_top.png", "\x89PNG\r\n\x1a\n"},
      {"reference.bt", "# Octomap OcTree binary file"}};
  for (const auto& [name, signature] : kinds) {
    const NamedPath output{"the output " + name, (out_dir / name).string()};
    const std::string why =
        signature.empty() ? FindForeignFileAtTrajectoryOutput(output)
                          : FindForeignFileAtOutput(output, signature, "an earlier run's " + name);
    if (!why.empty()) return why;
  }
  return "";
}

}  // namespace dygslam
