// The files of a run on a dataset folder (`dygslam run`, `dygslam component`), named as the user
// gave them, checked against each other before any work: no output replaces an input or another
// output, and no output replaces a user's file of another kind that happens to have its name.
//
//   RunFiles files{dataset_dir, {"--config", settings_path}, {{"--load-map", path}}, save_map,
//   out}; CheckRunFiles(files, system);              // UsageError naming both files
//   ClaimRunOutputs(files, &dataset);          // once the dataset's lists are read
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "core/io/dataset.h"
#include "core/io/file_util.h"
#include "core/system/system.h"

namespace dygslam {

struct RunFiles {
  std::string dataset_dir;        // "" or "-": none
  NamedPath settings;             // {"--config" or "the settings file", path}
  std::vector<NamedPath> given;   // input files given to options ({"--load-map", path}, ...)
  std::string save_map;           // the SLAM map file written at the end ("" none)
  std::filesystem::path out_dir;  // the output folder ("" none)
  // The files written into out_dir (empty: RunOutputNames(), those of `dygslam run`).
  std::vector<std::string> out_names;
  // Whether ClaimRunOutputs checks out_dir for a user's files (a component that writes no
  // output there, or checked it when it prepared the folder: false).
  bool claim_out_dir = true;
};

// The inputs: the dataset's lists, the settings file, the given files and the files the settings
// name (vocabulary, detector model).
std::vector<NamedPath> RunInputPaths(const RunFiles& files, const SystemOptions& system);
// The outputs: --save-map (when given) and every file of out_names in out_dir.
std::vector<NamedPath> RunOutputPaths(const RunFiles& files);

// Throws UsageError: an output that is an input or another output (FindOutputClash).
void CheckRunFiles(const RunFiles& files, const SystemOptions& system);
// Once the dataset's lists are read (`dataset`: nullptr when the command reads none), before any
// work. Throws UsageError: an output onto one of the dataset's images, an existing file at
// --save-map that is not a map file, a user's file of another kind at an output's name in
// out_dir (FindForeignFileInRunOutputs). Pins the folder of --save-map: the map goes into the
// folder there now, even if it is replaced while the run goes.
void ClaimRunOutputs(const RunFiles& files, const RgbdDataset* dataset);

// The first file in `out_dir` with the name of one of the outputs of `run`, `map` or a component
// (RunOutputNames, map's pictures) that is of another kind than that output (a settings file
// named map.bt, a text named map_top.png): why it is not replaced, "" when there is none. A
// command replaces its own earlier outputs only.
std::string FindForeignFileInRunOutputs(const std::filesystem::path& out_dir);
// Why `output` may not be written as a TUM trajectory: it exists and is not one (nor empty).
// "" when it may.
std::string FindForeignFileAtTrajectoryOutput(const NamedPath& output);

}  // namespace dygslam
