// dygslam map: the OctoMap of the static scene from the SLAM's keyframes (masks, pose
// corrections and culling applied) or from given poses (run/map_controller.h). SIGINT / SIGTERM:
// the map is finished from the frames so far, every output written, exit 0.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <optional>

#include "apps/command.h"
#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/config/settings.h"
#include "core/io/dataset.h"
#include "core/io/file_util.h"
#include "core/io/trajectory_io.h"
#include "core/system/system.h"
#include "mapping/octomap_builder.h"
#include "run/map_controller.h"
#include "run/run_files.h"
#include "run/run_inputs.h"
#include "run/run_settings.h"

namespace dygslam::cli {
namespace {
namespace fs = std::filesystem;

// The options of `dygslam map`.
void DefineMapOptions(ArgParser* parser) {
  ArgParser& p = *parser;
  p.AddPositional("DATASET_DIR", "folder with rgb.txt, depth.txt (groundtruth.txt optional)");
  p.AddOption("config", "FILE", "settings YAML; default: DATASET_DIR/camera.yaml or a preset");
  p.AddOption("filter", "MODE",
              "dynamic filter of the SLAM: none | boxes | geometry | paper | full", "full");
  p.AddOption("frames", "FIRST:LAST",
              "rgb.txt entries FIRST (inclusive, 0-based) to LAST (exclusive)");
  p.AddOption("out", "DIR", "output folder", "out/map");
  p.AddOption("trajectory", "FILE",
              "build the map from these poses (TUM format, e.g. groundtruth.txt) instead of the "
              "SLAM; no masks");
  p.AddOption("every", "N", "with --trajectory: use every N-th frame", "10");
  p.AddFlag("bonn-marker",
            "with --trajectory: poses are Bonn marker-body poses (apply the marker-to-camera "
            "calibration)");
  p.AddOption("resolution", "R", "leaf size in metres (overrides OctoMap.resolution)");
  p.AddFlag("no-mask", "insert every valid depth pixel (ignore the keyframes' dynamic masks)");
  p.AddOption("reference-until", "K",
              "also build a reference map from the keyframes before rgb entry K (e.g. people-free "
              "frames), without\n"
              "masks and with their final poses; print ghost voxels (occupied in the map, observed "
              "free in the\n"
              "reference); write DIR/reference.bt, DIR/ghosts_top.png, DIR/ghost_cells.txt");
  p.AddOption("save-every", "SECONDS",
              "also write map.bt/map.ot every SECONDS of wall time while running");
  p.AddFlag("deterministic",
            "fixed seeds and synchronous local mapping: identical output run to run");
  AddDatasetRunFlags(&p);
}

int RunMap(const std::vector<std::string>& args) {
  ArgParser p(
      "map",
      R"(DATASET_DIR [--config FILE] [--filter none|boxes|geometry|paper|full] [--frames FIRST:LAST] [--out DIR]
            [--trajectory FILE [--every N] [--bonn-marker]] [--deterministic] [--resolution R]
            [--no-mask] [--reference-until K] [--save-every SECONDS])",
      R"(Builds an occupancy map (OctoMap) of the static scene: runs the SLAM and inserts its keyframes with
the pixels judged dynamic left out (people), applying keyframe pose corrections. Writes DIR/map.bt
(max-likelihood, octovis), DIR/map.ot (probabilities), DIR/map_top.png (top view, coloured by
height), DIR/map_slice.png (occupancy slice just below the first camera's height) and
DIR/trajectory.txt (SLAM world = first camera frame). The map is levelled: z up with the floor at
z = 0, the first camera above the origin looking along +y (map_from_slam_world is printed;
--save-every snapshots are in the SLAM world). Map settings: the OctoMap: section of the settings.)");
  DefineMapOptions(&p);
  if (!p.Parse(args)) return p.exit_code();
  if (!CheckFilterOption(&p)) return 2;
  // Numbers first: a malformed or out-of-range one is a usage error (exit 2).
  MapControllerOptions o;
  int64_t reference_entry = 0;
  double resolution = 0;
  if ((p.Has("resolution") && !p.GetNumber("resolution", 0.001, 10, &resolution)) ||
      !p.GetInt("every", 1, 1000000, &o.every) ||
      (p.Has("reference-until") &&
       !p.GetInt("reference-until", 1, std::numeric_limits<int>::max(), &reference_entry)) ||
      (p.Has("save-every") && !p.GetNumber("save-every", 0.001, 1e9, &o.save_every_s.emplace())))
    return p.exit_code();
  const bool from_trajectory = p.Has("trajectory");
  if (!from_trajectory && (p.Has("every") || p.Flag("bonn-marker")))
    return p.UsageError("--every and --bonn-marker need --trajectory");
  if (p.Has("resolution") && !(resolution > 0.001))
    return p.UsageError("--resolution '" + EchoValue(p.Get("resolution")) +
                        "': expected a leaf size in metres above 0.001, at most 10");
  o.dataset_dir = p.Positional("DATASET_DIR");
  const std::string config =
      p.Has("config") ? p.Get("config") : DefaultSettingsPath(o.dataset_dir, ConfigDir());
  // The output folder first: a bad --out is found before the run, not after it.
  o.out = PrepareOutputDir("out", p.Get("out"));
  RunConfiguration configuration = LoadCommandSettings(p, config);
  // No output may replace an input or another output: checked before any work.
  const RunFiles files{o.dataset_dir,
                       {p.Has("config") ? "--config" : "the settings file", config},
                       {{"--trajectory", p.Get("trajectory")}},
                       "",
                       o.out,
                       MapOutputNames(from_trajectory)};
  CheckRunFiles(files, configuration.system);
  // The detector's model files before any output (SLAM maps): missing models fail here.
  if (!from_trajectory) ResolveDetectorModel(&configuration.system);
  o.system = configuration.system;
  o.octomap = configuration.octomap;
  if (p.Has("resolution")) o.octomap.resolution = resolution;
  if (p.Flag("no-mask") || o.system.filter.mode == FilterMode::kNone)
    o.octomap.use_dynamic_mask = false;
  o.octomap.Check();
  DatasetOptions dataset_options;
  dataset_options.refuse_outside_paths = p.Flag("strict-paths");
  const RgbdDataset dataset = RgbdDataset::Open(o.dataset_dir, dataset_options);
  ClaimRunOutputs(files, &dataset);  // nor onto a dataset image or a user's file
  if (!p.GetFrameRange("frames", dataset.num_rgb_entries(), &o.first, &o.last))
    return p.exit_code();
  if (p.Has("reference-until")) {
    if (static_cast<size_t>(reference_entry) > dataset.num_rgb_entries())
      return p.UsageError("--reference-until: expected an rgb entry index 1.." +
                          std::to_string(dataset.num_rgb_entries()));
    o.reference_until = dataset.StampOfRgbEntry(static_cast<size_t>(reference_entry));
    o.reference_name = p.Get("reference-until");
  }
  WarnAboutDataset("map", dataset, o.first, o.last, o.system.sensor.depth_map_factor,
                   o.system.camera.width, o.system.camera.height, nullptr);
  if (from_trajectory) {
    o.given_poses = ReadTumTrajectory(p.Get("trajectory"));
    o.trajectory_path = p.Get("trajectory");
    o.bonn_marker = p.Flag("bonn-marker");
  } else {
    o.every = 1;
  }
  o.progress = !p.Flag("quiet");
  return MapController(std::move(o), dataset).Run();
}

const CommandRegistrar kRegistrar({"map", "build a static occupancy map (OctoMap) of a dataset run",
                                   RunMap});

}  // namespace
}  // namespace dygslam::cli
