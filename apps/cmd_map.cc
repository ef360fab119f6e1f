// dygslam map DATASET_DIR [--config FILE] [--filter none|boxes|geometry|paper|full]
//              [--frames FIRST:LAST]
//              [--out DIR] [--trajectory FILE [--every N] [--bonn-marker]] [--deterministic]
//              [--resolution R] [--no-mask] [--reference-until K] [--save-every SECONDS]
//
// Runs the SLAM on a dataset folder and builds the OctoMap of the static scene from its keyframes
// (mapping/keyframe_mapper.h: new keyframes inserted with their dynamic masks, local-BA pose
// corrections and culled keyframes applied), or, with --trajectory, from given poses (e.g. the
// ground truth) without masks.
// SIGINT / SIGTERM stop it at any time like `run`: the map is finished from the frames processed so
// far, every output is written (atomically) and the exit code is 0.
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

// The files `map` writes into `out`.
std::vector<NamedPath> MapOutputs(const ArgParser& p, const fs::path& out) {
  std::vector<NamedPath> outputs;
  for (const char* name : {"map.bt", "map.ot", "map_top.png", "map_slice.png", "reference.bt",
                           "ghosts_top.png", "ghost_cells.txt"})
    outputs.push_back({"the output " + std::string(name), (out / name).string()});
  if (!p.Has("trajectory")) {
    for (const char* name : {"trajectory.txt", "keyframes.txt"})
      outputs.push_back({"the output " + std::string(name), (out / name).string()});
  }
  return outputs;
}

// No output may replace an input or another output, nor a user's file of an output's name:
// checked before any work. 0, or the usage error's exit code. (The dataset's images once its
// lists are read.)
int CheckMapOutputs(const ArgParser& p, const std::string& dataset_dir, const std::string& config,
                    const fs::path& out) {
  std::vector<NamedPath> inputs;
  for (const char* name : {"rgb.txt", "depth.txt", "groundtruth.txt", "associations.txt"})
    inputs.push_back(
        {std::string("the dataset's ") + name, (fs::path(dataset_dir) / name).string()});
  inputs.push_back({p.Has("config") ? "--config" : "the settings file", config});
  if (p.Has("trajectory")) inputs.push_back({"--trajectory", p.Get("trajectory")});
  if (const std::string clash = FindOutputClash(inputs, MapOutputs(p, out)); !clash.empty())
    return p.UsageError(clash);
  // An earlier map's files are replaced, never a user's files of the same names.
  if (const std::string foreign = FindForeignFileInRunOutputs(out); !foreign.empty())
    return p.UsageError(foreign);
  return 0;
}

int RunMap(const std::vector<std::string>& args) {
  ArgParser p("map", R"(DATASET_DIR [--config FILE] [--filter none|boxes|geometry|paper|full] [--frames FIRST:LAST] [--out DIR]
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
  double resolution = 0;
  int every_option = 0;
  int64_t reference_entry = 0;
  std::optional<double> save_every;
  if ((p.Has("resolution") && !p.GetNumber("resolution", 0.001, 10, &resolution)) ||
      !p.GetInt("every", 1, 1000000, &every_option) ||
      (p.Has("reference-until") &&
       !p.GetInt("reference-until", 1, std::numeric_limits<int>::max(), &reference_entry)) ||
      (p.Has("save-every") && !p.GetNumber("save-every", 0.001, 1e9, &save_every.emplace())))
    return p.exit_code();

  const std::string dataset_dir = p.Positional("DATASET_DIR");
  const std::string config =
      p.Has("config") ? p.Get("config") : DefaultSettingsPath(dataset_dir, ConfigDir());
  // The output folder first: a bad --out is found before the run, not after it.
  const fs::path out = PrepareOutputDir("out", p.Get("out"));
  if (const int code = CheckMapOutputs(p, dataset_dir, config, out); code != 0) return code;

  RunConfiguration configuration =
      LoadRunConfiguration({config, CliSettingsReadOptions(p.Flag("strict-settings")),
                            p.Get("filter"), p.Flag("deterministic")});
  // The detector's model files before any output (SLAM maps): missing models fail here.
  if (!p.Has("trajectory")) ResolveDetectorModel(&configuration.system);
  const SystemOptions& options = configuration.system;
  OctoMapOptions& map_options = configuration.octomap;
  if (p.Has("resolution")) map_options.resolution = resolution;
  if (p.Flag("no-mask") || options.filter.mode == FilterMode::kNone)
    map_options.use_dynamic_mask = false;
  if (p.Has("resolution") && !(map_options.resolution > 0.001 && map_options.resolution <= 10))
    return p.UsageError("--resolution '" + EchoValue(p.Get("resolution")) +
                        "': expected a leaf size in metres above 0.001, at most 10");
  map_options.Check();
  const bool from_trajectory = p.Has("trajectory");
  int every = 1;
  if (from_trajectory) {
    every = every_option;
  } else if (p.Has("every") || p.Flag("bonn-marker")) {
    return p.UsageError("--every and --bonn-marker need --trajectory");
  }

  DatasetOptions dataset_options;
  dataset_options.refuse_outside_paths = p.Flag("strict-paths");
  const RgbdDataset dataset = RgbdDataset::Open(dataset_dir, dataset_options);
  if (const std::string clash = FindOutputOnDatasetImage(dataset, dataset_dir, MapOutputs(p, out));
      !clash.empty())
    return p.UsageError(clash);
  size_t first = 0, last = 0;
  if (!p.GetFrameRange("frames", dataset.num_rgb_entries(), &first, &last)) return p.exit_code();
  std::optional<Timestamp> reference_until;
  if (p.Has("reference-until")) {
    if (static_cast<size_t>(reference_entry) > dataset.num_rgb_entries())
      return p.UsageError("--reference-until: expected an rgb entry index 1.." +
                          std::to_string(dataset.num_rgb_entries()));
    reference_until = dataset.StampOfRgbEntry(static_cast<size_t>(reference_entry));
  }
  WarnAboutDataset("map", dataset, first, last, options.sensor.depth_map_factor,
                   options.camera.width, options.camera.height, nullptr);
  MapControllerOptions o;
  o.dataset_dir = dataset_dir;
  o.system = options;
  o.octomap = map_options;
  o.first = first;
  o.last = last;
  o.out = out;
  if (from_trajectory) {
    o.given_poses = ReadTumTrajectory(p.Get("trajectory"));
    o.trajectory_path = p.Get("trajectory");
    o.every = every;
    o.bonn_marker = p.Flag("bonn-marker");
  }
  o.reference_until = reference_until;
  o.reference_name = p.Get("reference-until");
  o.save_every_s = save_every;
  o.progress = !p.Flag("quiet");
  MapController controller(std::move(o), dataset);
  return controller.Run();
}

const CommandRegistrar kRegistrar({"map", "build a static occupancy map (OctoMap) of a dataset run",
                                   RunMap});

}  // namespace
}  // namespace dygslam::cli
