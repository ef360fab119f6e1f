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
#include <octomap/OcTree.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <limits>
#include <map>
#include <mutex>
#include <optional>

#include "apps/command.h"
#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/base/stop_signal.h"
#include "core/config/settings.h"
#include "core/io/bonn.h"
#include "core/io/dataset.h"
#include "core/io/file_util.h"
#include "core/io/trajectory_io.h"
#include "core/system/system.h"
#include "mapping/keyframe_mapper.h"
#include "mapping/map_compare.h"
#include "mapping/map_frame.h"
#include "mapping/map_render.h"
#include "mapping/octomap_builder.h"
#include "run/dataset_runner.h"
#include "run/run_outputs.h"
#include "run/run_settings.h"

namespace dygslam::cli {
namespace {
namespace fs = std::filesystem;

// Keyframes recorded for the reference map (--reference-until): depth kept, final pose tracked.
struct ReferenceKeyframe {
  Timestamp stamp;
  cv::Mat depth;
  Rigid3d world_from_cam;
  bool removed = false;
};

std::string Count(uint64_t n) { return std::to_string(n); }

int RunMap(const std::vector<std::string>& args) {
  ArgParser p(
      "map",
      "DATASET_DIR [--config FILE] [--filter none|boxes|geometry|paper|full] [--frames FIRST:LAST] "
      "[--out DIR]\n"
      "            [--trajectory FILE [--every N] [--bonn-marker]] [--deterministic] [--resolution "
      "R]\n"
      "            [--no-mask] [--reference-until K] [--save-every SECONDS]",
      "Builds an occupancy map (OctoMap) of the static scene: runs the SLAM and inserts its "
      "keyframes with\n"
      "the pixels judged dynamic left out (people), applying keyframe pose corrections. Writes "
      "DIR/map.bt\n"
      "(max-likelihood, octovis), DIR/map.ot (probabilities), DIR/map_top.png (top view, coloured "
      "by\n"
      "height), DIR/map_slice.png (occupancy slice just below the first camera's height) and\n"
      "DIR/trajectory.txt (SLAM world = first camera frame). The map is levelled: z up with the "
      "floor at\n"
      "z = 0, the first camera above the origin looking along +y (map_from_slam_world is printed;\n"
      "--save-every snapshots are in the SLAM world). Map settings: the OctoMap: section of the "
      "settings.");
  p.AddPositional("DATASET_DIR", "folder with rgb.txt, depth.txt (groundtruth.txt optional)");
  p.AddOption("config", "FILE", "settings YAML; default: DATASET_DIR/camera.yaml or a preset");
  p.AddOption("filter", "MODE",
              "dynamic filter of the SLAM: none | boxes | geometry | full | paper (+margin, "
              "+margin+demotion)",
              "full");
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
  if (!p.Parse(args)) return p.exit_code();
  if (!CheckFilterOption(&p)) return 2;
  // A stop request ends the frame loop; the outputs are then written from what was processed
  // (shares the flag of dygslam main's early scope, so a signal during setup counts too).
  const StopFlag stop(StopFlag::Signals::kStop);
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
  // No output may replace an input or another output: checked before any work (exit 2).
  {
    std::vector<NamedPath> inputs;
    for (const char* name : {"rgb.txt", "depth.txt", "groundtruth.txt", "associations.txt"})
      inputs.push_back(
          {std::string("the dataset's ") + name, (fs::path(dataset_dir) / name).string()});
    inputs.push_back({p.Has("config") ? "--config" : "the settings file", config});
    if (p.Has("trajectory")) inputs.push_back({"--trajectory", p.Get("trajectory")});
    std::vector<NamedPath> outputs;
    for (const char* name : {"map.bt", "map.ot", "map_top.png", "map_slice.png", "reference.bt",
                             "ghosts_top.png", "ghost_cells.txt"})
      outputs.push_back({"the output " + std::string(name), (out / name).string()});
    if (!p.Has("trajectory")) {
      for (const char* name : {"trajectory.txt", "keyframes.txt"})
        outputs.push_back({"the output " + std::string(name), (out / name).string()});
    }
    if (const std::string clash = FindOutputClash(inputs, outputs); !clash.empty())
      return p.UsageError(clash);
    // An earlier map's files are replaced, never a user's files of the same names.
    if (const std::string foreign = FindForeignFileInRunOutputs(out); !foreign.empty())
      return p.UsageError(foreign);
  }

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
  std::pair<size_t, size_t> range{0, dataset.num_rgb_entries()};
  std::string frames_note;  // --frames beyond the dataset: cut, with a warning
  if (p.Has("frames")) {
    try {  // a malformed or out-of-range --frames is a usage error (exit 2), as other numbers
      range = ParseFrameRange(p.Get("frames"), dataset.num_rgb_entries(), &frames_note);
    } catch (const std::exception& e) {
      return p.UsageError(e.what());
    }
  }
  if (!frames_note.empty()) std::fprintf(stderr, "dygslam map: warning: %s\n", frames_note.c_str());
  auto [first, last] = range;
  std::optional<Timestamp> reference_until;
  if (p.Has("reference-until")) {
    if (static_cast<size_t>(reference_entry) > dataset.num_rgb_entries())
      return p.UsageError("--reference-until: expected an rgb entry index 1.." +
                          std::to_string(dataset.num_rgb_entries()));
    // The stamp of rgb entry K: the first frame with a depth partner at or after it.
    for (size_t e = static_cast<size_t>(reference_entry);
         e < dataset.num_rgb_entries() && !reference_until; ++e) {
      if (const auto index = dataset.FrameForRgbEntry(e))
        reference_until = dataset.frame(*index).rgb_stamp;
    }
    if (!reference_until)
      reference_until =
          Timestamp::FromNanoseconds(dataset.frames().back().rgb_stamp.nanoseconds() + 1);
  }
  WarnAboutDataset("map", dataset, first, last, options.sensor.depth_map_factor,
                   options.camera.width, options.camera.height, nullptr);
  std::vector<StampedPose> given_poses;
  if (from_trajectory) {
    given_poses = ReadTumTrajectory(p.Get("trajectory"));
    // A trajectory of another sequence (or stamps in another unit) gives no frame a pose: an
    // error before any work, not an empty map.
    size_t with_pose = 0, frames = 0;
    Timestamp first_stamp, last_stamp;
    for (size_t k = first; k < last; ++k) {
      const auto index = dataset.FrameForRgbEntry(k);
      if (!index) continue;
      if (frames++ == 0) first_stamp = dataset.frame(*index).rgb_stamp;
      last_stamp = dataset.frame(*index).rgb_stamp;
      if (InterpolatePose(given_poses, dataset.frame(*index).rgb_stamp)) ++with_pose;
    }
    if (with_pose == 0) {
      std::string span = "no pose";
      if (!given_poses.empty())
        span = "poses from " + given_poses.front().stamp.ToString() + " to " +
               given_poses.back().stamp.ToString() + " s";
      std::string frames_span = "no frame";
      if (frames > 0)
        frames_span = std::to_string(frames) + " frames from " + first_stamp.ToString() + " to " +
                      last_stamp.ToString() + " s";
      throw InputError(p.Get("trajectory"), 0,
                       "--trajectory gives none of the range's frames a pose (" + span +
                           "; the range has " + frames_span +
                           "): is it the trajectory of another sequence?");
    }
  }

  // Background rebuilds after pose corrections keep the live map exact at a bounded cost; a
  // deterministic run leaves them to the final read so that the map is the same every time.
  KeyframeMapperOptions mapper_options;
  if (options.deterministic) mapper_options.max_rebuild_share = 0;
  KeyframeMapper mapper(options.camera, map_options, mapper_options);
  std::mutex
      record_mutex;  // guards the records below (the callback may run on the local-mapping thread)
  std::map<int64_t, ReferenceKeyframe> reference;
  std::vector<Timestamp> keyframe_stamps;
  std::optional<Rigid3d> first_camera;
  auto on_keyframe = [&](const KeyframeData& keyframe) {
    {
      std::lock_guard<std::mutex> lock(record_mutex);
      const bool is_new = !keyframe.pose_update_only && !keyframe.removed;
      if (is_new) {
        keyframe_stamps.push_back(keyframe.stamp);
        if (!first_camera) first_camera = keyframe.world_from_cam;
      }
      if (reference_until) {
        if (is_new && keyframe.stamp < *reference_until) {
          reference[keyframe.id] = {keyframe.stamp, keyframe.depth.clone(), keyframe.world_from_cam,
                                    false};
        } else if (auto it = reference.find(keyframe.id); it != reference.end()) {
          // A culled people-free keyframe still observed the scene: keep it, at its last pose.
          if (keyframe.removed)
            it->second.removed = true;
          else
            it->second.world_from_cam = keyframe.world_from_cam;
        }
      }
    }
    mapper.Submit(keyframe);
  };

  std::optional<System> system;
  if (!from_trajectory) {
    system.emplace(options);
    system->SetKeyframeCallback(on_keyframe);
  }
  const bool progress = !p.Flag("quiet");
  size_t processed = 0, lost = 0, skipped = 0, saves = 0;
  const auto t0 = std::chrono::steady_clock::now();
  auto last_save = t0;
  auto save_maps = [&]() {
    mapper.WithBuilder([&](OctoMapBuilder& builder) {
      builder.WriteBinary((out / "map.bt").string());
      builder.WriteFull((out / "map.ot").string());
    });
    ++saves;
  };
  // After each frame fed (SLAM) or inserted (--trajectory): periodic saves, progress line.
  auto after_frame = [&](size_t k, TrackingState state) {
    ++processed;
    const auto now = std::chrono::steady_clock::now();
    if (save_every && std::chrono::duration<double>(now - last_save).count() >= *save_every) {
      save_maps();
      last_save = now;
    }
    if (progress && (processed % 10 == 0 || k + 1 == last)) {
      const double elapsed = std::chrono::duration<double>(now - t0).count();
      size_t num_keyframes;
      {
        std::lock_guard<std::mutex> lock(record_mutex);
        num_keyframes = keyframe_stamps.size();
      }
      const MapperStats ms = mapper.Stats();
      std::fprintf(
          stderr, "\r[map] frame %zu/%zu  %.1f fps  state=%s  keyframes=%zu  map queue=%zu   ",
          k + 1 - first, last - first, processed / std::max(elapsed, 1e-9), ToString(state),
          num_keyframes, ms.num_submitted - ms.num_applied - ms.num_coalesced);
      std::fflush(stderr);
    }
  };
  auto stop_requested = [&stop] { return stop.requested(); };
  bool interrupted = false;
  // Bad input found mid-run (an image that does not decode) ends the frame loop, but the map and
  // every output are written from the frames before it (as on a stop signal); then the error is
  // reported (exit 1).
  std::exception_ptr failure;
  try {
    if (from_trajectory) {
      for (size_t k = first; k < last; ++k) {
        if (stop_requested()) {
          interrupted = true;
          break;
        }
        const auto index = dataset.FrameForRgbEntry(k);
        if (!index) {
          ++skipped;
          continue;
        }
        if ((k - first) % every != 0) continue;
        const Timestamp stamp = dataset.frame(*index).rgb_stamp;
        std::optional<Rigid3d> pose = InterpolatePose(given_poses, stamp);
        if (!pose) {
          ++lost;
          continue;
        }
        if (p.Flag("bonn-marker")) *pose = *pose * BonnMarkerFromCam();
        KeyframeData keyframe;
        keyframe.id = static_cast<int64_t>(k);
        keyframe.stamp = stamp;
        keyframe.world_from_cam = *pose;
        dataset.LoadDepth(*index, options.camera.width, options.camera.height)
            .convertTo(keyframe.depth, CV_32F, 1.0 / options.sensor.depth_map_factor);
        on_keyframe(keyframe);
        after_frame(k, TrackingState::kOk);
      }
    } else {
      DatasetRunOptions run;
      run.first_entry = first;
      run.last_entry = last;
      run.image_width = options.camera.width;
      run.image_height = options.camera.height;
      run.prefetch_detections = false;
      run.stop = stop_requested;
      const DatasetRunSummary summary =
          RunDatasetFrames(dataset, *system, run, [&](size_t k, const FrameResult& r) {
            if (r.state == TrackingState::kLost)
              ++lost;  // also counted when an error ends the loop
            after_frame(k, r.state);
          });
      lost = summary.lost;
      skipped = summary.skipped;
      interrupted = summary.interrupted;
    }
  } catch (const std::exception&) {
    failure = std::current_exception();
  }
  if (progress) std::fprintf(stderr, "\n");
  if (system) system->Shutdown();  // last local-mapping corrections reach the mapper
  mapper.Flush();
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  RecreateOutputDirIfRemoved("map", "out", out);
  if (system) WriteSystemTrajectories(out.string(), *system);

  // SLAM maps: level the map (z up, floor at z = 0) by the floor it found, so pictures and
  // planners see it upright. A rigid change of the world frame: all stored keyframe poses move,
  // the tree is rebuilt once.
  std::optional<FloorEstimate> floor;
  Rigid3d map_from_world;
  if (system && first_camera) {
    const Eigen::Vector3d prior_up = first_camera->rotation * -Eigen::Vector3d::UnitY();
    mapper.WithBuilder([&](OctoMapBuilder& builder) {
      floor = EstimateFloor(builder.tree(), prior_up, first_camera->translation);
      map_from_world = LevelFrameFromWorld(*floor, prior_up, *first_camera);
      std::map<int64_t, Rigid3d> moved;
      for (int64_t id : builder.KeyframeIds()) moved[id] = map_from_world * builder.Pose(id);
      builder.UpdatePoses(moved);
    });
    for (auto& [id, kf] : reference) kf.world_from_cam = map_from_world * kf.world_from_cam;
    first_camera = map_from_world * *first_camera;
  }

  // Outputs and figures.
  OctoMapStats stats;
  std::optional<GhostVoxelCounts> ghosts;
  size_t reference_keyframes = 0;
  const double camera_z = first_camera ? first_camera->translation.z() : 0.0;
  const bool has_floor = floor && floor->found;
  mapper.WithBuilder([&](OctoMapBuilder& builder) {
    const auto t_sync = std::chrono::steady_clock::now();
    builder.Finalize();  // the map of the final poses
    const double final_sync_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_sync)
            .count();
    stats = builder.Stats();
    builder.WriteBinary((out / "map.bt").string());
    builder.WriteFull((out / "map.ot").string());
    // Top view without the ceiling (up to 2 m above the floor, or 0.7 m above the first camera
    // when the map frame is not levelled by a floor); slice at 1 m above the floor (or 0.3 m
    // below the camera).
    TopViewOptions top;
    top.max_z = has_floor ? 2.0 : camera_z + 0.7;
    WritePngAtomically((out / "map_top.png").string(), RenderTopView(builder.tree(), top));
    WritePngAtomically((out / "map_slice.png").string(),
                       RenderSlice(builder.tree(), has_floor ? 1.0 : camera_z - 0.3));
    if (reference_until) {
      OctoMapOptions reference_options = map_options;
      reference_options.use_dynamic_mask = false;
      OctoMapBuilder reference_map(options.camera, reference_options);
      for (const auto& [id, kf] : reference) {
        KeyframeData data;
        data.id = id;
        data.stamp = kf.stamp;
        data.depth = kf.depth;
        // The map's final pose of the keyframe (culled ones: their last pose).
        data.world_from_cam = builder.Contains(id) ? builder.Pose(id) : kf.world_from_cam;
        reference_map.Insert(data);
        ++reference_keyframes;
      }
      reference_map.WriteBinary((out / "reference.bt").string());
      std::vector<octomap::point3d> ghost_cells;
      ghosts = CompareGhostVoxels(builder.tree(), reference_map.tree(), 1, &ghost_cells);
      // Where the ghosts are: a top view of the ghost cells alone.
      octomap::OcTree ghost_map(builder.tree().getResolution());
      for (const octomap::point3d& c : ghost_cells) ghost_map.updateNode(c, true);
      TopViewOptions ghost_top;
      ghost_top.draw_free = false;
      WritePngAtomically((out / "ghosts_top.png").string(), RenderTopView(ghost_map, ghost_top));
      std::string lines = "# ghost cell centres (map frame, m): x y z\n";
      char line[96];
      for (const octomap::point3d& c : ghost_cells) {
        std::snprintf(line, sizeof(line), "%.3f %.3f %.3f\n", c.x(), c.y(), c.z());
        lines += line;
      }
      WriteFileAtomically((out / "ghost_cells.txt").string(), lines);
    }
    std::printf("final map sync (rebuild after pose corrections): %.1f ms\n", final_sync_ms);
  });

  const MapperStats ms = mapper.Stats();
  if (interrupted) {
    std::printf(
        "interrupted by a signal after %zu of %zu frames: map and outputs written from them\n",
        processed, last - first);
  }
  if (system) {
    std::printf(
        "frames: %zu processed, %zu lost, %zu without depth partner; %.1f fps (SLAM + map)\n",
        processed, lost, skipped, processed / std::max(elapsed, 1e-9));
    std::printf("filter: %s%s; map masks %s\n", ToString(options.filter.mode),
                options.deterministic ? " (deterministic)" : "",
                map_options.use_dynamic_mask ? "applied" : "not applied");
  } else {
    std::printf("frames: %zu inserted from %s (every %d), %zu without pose\n", processed,
                EchoValue(p.Get("trajectory")).c_str(), every, lost);
  }
  std::printf(
      "keyframes: %zu in the map (%zu inserted, %zu pose corrections, %zu culled), %llu rebuilds\n",
      stats.num_keyframes, ms.num_new_keyframes, ms.num_pose_updates + ms.num_coalesced,
      ms.num_removals, static_cast<unsigned long long>(stats.num_rebuilds));
  std::printf(
      "map: resolution %.3f m, %zu leaves (%zu occupied, %zu free), %s occupied / %s free cells, "
      "%.2f MB\n",
      map_options.resolution, stats.num_leaves, stats.num_occupied_leaves, stats.num_free_leaves,
      Count(stats.num_occupied_voxels).c_str(), Count(stats.num_free_voxels).c_str(),
      stats.memory_bytes / 1048576.0);
  std::printf(
      "insertion per keyframe: median %.1f ms wall, %.1f ms CPU; last rebuild %.1f ms wall, %.1f "
      "ms CPU for "
      "%zu keyframes\n",
      stats.median_insert_ms, stats.median_insert_cpu_ms, stats.last_rebuild_ms,
      stats.last_rebuild_cpu_ms, stats.num_keyframes);
  if (keyframe_stamps.size() >= 2) {
    const double span = SecondsBetween(keyframe_stamps.front(), keyframe_stamps.back());
    const double keyframe_rate = (keyframe_stamps.size() - 1) / std::max(span, 1e-9);
    // Real time: keyframes arrive at keyframe_rate per second of sequence time; one core inserts
    // 1000 / (CPU ms per keyframe) of them per second.
    const double capacity =
        stats.median_insert_cpu_ms > 0 ? 1000.0 / stats.median_insert_cpu_ms : 0.0;
    std::printf(
        "keyframe rate %.2f /s (sequence time, %zu keyframes in %.1f s); mapper capacity %.1f "
        "keyframes/s "
        "of one core (%s at the sequence's frame rate); this run: queue max %zu, latency median "
        "%.1f ms, "
        "max %.1f ms, mapper busy %.1f s of %.1f s\n",
        keyframe_rate, keyframe_stamps.size(), span, capacity,
        capacity > keyframe_rate ? "keeps up" : "falls behind", ms.max_queue_depth,
        ms.median_latency_ms, ms.max_latency_ms, ms.worker_busy_ms / 1000.0, elapsed);
    if (ms.num_blocked > 0) {
      std::printf("map queue full: the SLAM's keyframe callback waited %zu times (back-pressure)\n",
                  ms.num_blocked);
    }
    if (ms.num_background_rebuilds > 0) {
      std::printf("background rebuilds after pose corrections: %zu, %.1f s in total\n",
                  ms.num_background_rebuilds, ms.background_rebuild_ms / 1000.0);
    }
  }
  if (floor) {
    if (floor->found) {
      std::printf(
          "map frame: levelled on the floor (%zu cells, %.1f deg from the first camera's up); "
          "first camera %.2f m above it\n",
          floor->num_inliers, floor->tilt_from_prior_deg, camera_z);
    } else {
      std::printf(
          "map frame: no floor found; z = up in the first image, first camera at the origin\n");
    }
    const Eigen::Quaterniond q = map_from_world.rotation;
    std::printf("map_from_slam_world (tx ty tz qx qy qz qw): %.6f %.6f %.6f %.6f %.6f %.6f %.6f\n",
                map_from_world.translation.x(), map_from_world.translation.y(),
                map_from_world.translation.z(), q.x(), q.y(), q.z(), q.w());
  }
  if (ghosts) {
    std::printf("reference: %zu keyframes before rgb entry %s\n", reference_keyframes,
                EchoValue(p.Get("reference-until")).c_str());
    std::printf(
        "ghost voxels: %s (occupied in the map, observed free in the reference, no reference "
        "surface "
        "within 1 cell); occupied-and-free %s; map occupied %s, reference occupied %s\n",
        Count(ghosts->ghost).c_str(), Count(ghosts->occupied_a_free_b).c_str(),
        Count(ghosts->occupied_in_a).c_str(), Count(ghosts->occupied_in_b).c_str());
  }
  if (saves > 0) std::printf("periodic saves: %zu\n", saves);
  std::printf("outputs: %s/{map.bt,map.ot,map_top.png,map_slice.png%s%s}\n", out.string().c_str(),
              system ? ",trajectory.txt,keyframes.txt" : "",
              ghosts ? ",reference.bt,ghosts_top.png,ghost_cells.txt" : "");
  if (failure) {
    std::fprintf(stderr,
                 "[map] stopped by an error after %zu frames: the map and outputs of those frames "
                 "are written to %s\n",
                 processed, out.string().c_str());
    std::rethrow_exception(failure);
  }
  // A SLAM map from (almost) no tracked frame is no map of the scene: fail, and say why.
  if (system && !interrupted) {
    const size_t tracked = system->Trajectory().size();
    if (IsTrackingFailure(processed, tracked)) {
      PrintTrackingFailure("map", processed, tracked, lost);
      return 1;
    }
  }
  return 0;
}

const CommandRegistrar kRegistrar({"map", "build a static occupancy map (OctoMap) of a dataset run",
                                   RunMap});

}  // namespace
}  // namespace dygslam::cli
