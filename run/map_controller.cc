#include "run/map_controller.h"

#include <octomap/OcTree.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <exception>
#include <functional>
#include <utility>

#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/base/stop_signal.h"
#include "core/io/bonn.h"
#include "core/io/file_util.h"
#include "core/io/trajectory_io.h"
#include "mapping/map_render.h"
#include "run/dataset_runner.h"
#include "run/run_outputs.h"
#include "run/run_summary.h"

namespace dygslam {
namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

std::string Count(uint64_t n) { return std::to_string(n); }

// Background rebuilds after pose corrections keep the live map exact at a bounded cost; a
// deterministic run leaves them to the final read so that the map is the same every time.
KeyframeMapperOptions MapperOptionsFor(const SystemOptions& system) {
  KeyframeMapperOptions options;
  if (system.deterministic) options.max_rebuild_share = 0;
  return options;
}

// A trajectory of another sequence (or stamps in another unit) gives no frame a pose: an error
// before any work, not an empty map.
void CheckPosesCoverRange(const MapControllerOptions& o, const RgbdDataset& dataset) {
  const std::vector<StampedPose>& poses = *o.given_poses;
  size_t with_pose = 0, frames = 0;
  Timestamp first_stamp, last_stamp;
  for (size_t k = o.first; k < o.last; ++k) {
    const auto index = dataset.FrameForRgbEntry(k);
    if (!index) continue;
    if (frames++ == 0) first_stamp = dataset.frame(*index).rgb_stamp;
    last_stamp = dataset.frame(*index).rgb_stamp;
    if (InterpolatePose(poses, dataset.frame(*index).rgb_stamp)) ++with_pose;
  }
  if (with_pose > 0) return;
  std::string span = "no pose";
  if (!poses.empty())
    span = "poses from " + poses.front().stamp.ToString() + " to " + poses.back().stamp.ToString() +
           " s";
  std::string frames_span = "no frame";
  if (frames > 0)
    frames_span = std::to_string(frames) + " frames from " + first_stamp.ToString() + " to " +
                  last_stamp.ToString() + " s";
  throw InputError(o.trajectory_path, 0,
                   "--trajectory gives none of the range's frames a pose (" + span +
                       "; the range has " + frames_span +
                       "): is it the trajectory of another sequence?");
}

}  // namespace

void MapControllerOptions::Check() const {
  if (dataset_dir.empty()) throw InvalidOptions("MapControllerOptions.dataset_dir is empty");
  if (out.empty()) throw InvalidOptions("MapControllerOptions.out is empty");
  if (last < first)
    throw InvalidOptions("MapControllerOptions.last (" + std::to_string(last) +
                         ") is before first (" + std::to_string(first) + ")");
  if (every < 1) throw InvalidOptions("MapControllerOptions.every must be at least 1");
  if (!given_poses && (every != 1 || bonn_marker))
    throw InvalidOptions("MapControllerOptions.every / bonn_marker need given_poses");
  if (save_every_s && !(*save_every_s > 0))
    throw InvalidOptions("MapControllerOptions.save_every_s must be > 0");
  octomap.Check();
}

std::vector<std::string> MapOutputNames(bool from_given_poses) {
  std::vector<std::string> names = {"map.bt",         "map.ot",       "map_top.png",
                                    "map_slice.png",  "reference.bt", "ghosts_top.png",
                                    "ghost_cells.txt"};
  if (!from_given_poses) names.insert(names.end(), {"trajectory.txt", "keyframes.txt"});
  return names;
}

MapController::MapController(MapControllerOptions options, const RgbdDataset& dataset)
    : options_(std::move(options)),
      dataset_(dataset),
      mapper_(options_.system.camera, options_.octomap, MapperOptionsFor(options_.system)) {
  options_.Check();
  if (options_.given_poses) CheckPosesCoverRange(options_, dataset_);
}

void MapController::OnKeyframe(const KeyframeData& keyframe) {
  {
    std::lock_guard<std::mutex> lock(record_mutex_);
    const bool is_new = !keyframe.pose_update_only && !keyframe.removed;
    if (is_new) {
      keyframe_stamps_.push_back(keyframe.stamp);
      if (!first_camera_) first_camera_ = keyframe.world_from_cam;
    }
    if (options_.reference_until) {
      if (is_new && keyframe.stamp < *options_.reference_until) {
        reference_[keyframe.id] = {keyframe.stamp, keyframe.depth.clone(), keyframe.world_from_cam,
                                   false};
      } else if (auto it = reference_.find(keyframe.id); it != reference_.end()) {
        // A culled people-free keyframe still observed the scene: keep it, at its last pose.
        if (keyframe.removed)
          it->second.removed = true;
        else
          it->second.world_from_cam = keyframe.world_from_cam;
      }
    }
  }
  mapper_.Submit(keyframe);
}

void MapController::SaveMaps() {
  mapper_.WithBuilder([&](OctoMapBuilder& builder) {
    builder.WriteBinary((options_.out / "map.bt").string());
    builder.WriteFull((options_.out / "map.ot").string());
  });
  ++saves_;
}

// After each frame fed (SLAM) or inserted (given poses): periodic saves, progress line.
void MapController::AfterFrame(size_t k, TrackingState state) {
  ++processed_;
  const auto now = Clock::now();
  if (options_.save_every_s &&
      std::chrono::duration<double>(now - last_save_).count() >= *options_.save_every_s) {
    SaveMaps();
    last_save_ = now;
  }
  if (options_.progress && (processed_ % 10 == 0 || k + 1 == options_.last)) {
    const double elapsed = std::chrono::duration<double>(now - t0_).count();
    size_t num_keyframes;
    {
      std::lock_guard<std::mutex> lock(record_mutex_);
      num_keyframes = keyframe_stamps_.size();
    }
    const MapperStats ms = mapper_.Stats();
    std::fprintf(stderr,
                 "\r[map] frame %zu/%zu  %.1f fps  state=%s  keyframes=%zu  map queue=%zu   ",
                 k + 1 - options_.first, options_.last - options_.first,
                 processed_ / std::max(elapsed, 1e-9), ToString(state), num_keyframes,
                 ms.num_submitted - ms.num_applied - ms.num_coalesced);
    std::fflush(stderr);
  }
}

void MapController::FeedGivenPoses(const std::function<bool()>& stop_requested) {
  const MapControllerOptions& o = options_;
  for (size_t k = o.first; k < o.last; ++k) {
    if (stop_requested()) {
      interrupted_ = true;
      break;
    }
    const auto index = dataset_.FrameForRgbEntry(k);
    if (!index) {
      ++skipped_;
      continue;
    }
    if ((k - o.first) % o.every != 0) continue;
    const Timestamp stamp = dataset_.frame(*index).rgb_stamp;
    std::optional<Rigid3d> pose = InterpolatePose(*o.given_poses, stamp);
    if (!pose) {
      ++lost_;
      continue;
    }
    if (o.bonn_marker) *pose = *pose * BonnMarkerFromCam();
    RgbdFrame frame;
    frame.depth = dataset_.LoadDepth(*index, o.system.camera.width, o.system.camera.height);
    frame.depth_scale = o.system.sensor.depth_map_factor;
    KeyframeData keyframe;
    keyframe.id = static_cast<int64_t>(k);
    keyframe.stamp = stamp;
    keyframe.world_from_cam = *pose;
    keyframe.depth = frame.DepthInMetres();
    OnKeyframe(keyframe);
    AfterFrame(k, TrackingState::kOk);
  }
}

void MapController::FeedSlam(const std::function<bool()>& stop_requested) {
  DatasetRunOptions run;
  run.first_entry = options_.first;
  run.last_entry = options_.last;
  run.image_width = options_.system.camera.width;
  run.image_height = options_.system.camera.height;
  run.prefetch_detections = false;
  run.stop = stop_requested;
  const DatasetRunSummary summary =
      RunDatasetFrames(dataset_, *system_, run, [&](size_t k, const FrameResult& r) {
        if (r.state == TrackingState::kLost) ++lost_;  // also counted when an error ends the loop
        AfterFrame(k, r.state);
      });
  lost_ = summary.lost;
  skipped_ = summary.skipped;
  interrupted_ = summary.interrupted;
}

void MapController::LevelMap() {
  // A rigid change of the world frame: all stored keyframe poses move, the tree is rebuilt once.
  const Eigen::Vector3d prior_up = first_camera_->rotation * -Eigen::Vector3d::UnitY();
  mapper_.WithBuilder([&](OctoMapBuilder& builder) {
    floor_ = EstimateFloor(builder.tree(), prior_up, first_camera_->translation);
    map_from_world_ = LevelFrameFromWorld(*floor_, prior_up, *first_camera_);
    std::map<int64_t, Rigid3d> moved;
    for (int64_t id : builder.KeyframeIds()) moved[id] = map_from_world_ * builder.Pose(id);
    builder.UpdatePoses(moved);
  });
  for (auto& [id, kf] : reference_) kf.world_from_cam = map_from_world_ * kf.world_from_cam;
  first_camera_ = map_from_world_ * *first_camera_;
}

void MapController::WriteReference(OctoMapBuilder& builder, MapFigures* figures) {
  const fs::path& out = options_.out;
  OctoMapOptions reference_options = options_.octomap;
  reference_options.use_dynamic_mask = false;
  OctoMapBuilder reference_map(options_.system.camera, reference_options);
  for (const auto& [id, kf] : reference_) {
    KeyframeData data;
    data.id = id;
    data.stamp = kf.stamp;
    data.depth = kf.depth;
    // The map's final pose of the keyframe (culled ones: their last pose).
    data.world_from_cam = builder.Contains(id) ? builder.Pose(id) : kf.world_from_cam;
    reference_map.Insert(data);
    ++figures->reference_keyframes;
  }
  reference_map.WriteBinary((out / "reference.bt").string());
  std::vector<octomap::point3d> ghost_cells;
  figures->ghosts = CompareGhostVoxels(builder.tree(), reference_map.tree(), 1, &ghost_cells);
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

MapController::MapFigures MapController::WriteMaps() {
  const fs::path& out = options_.out;
  MapFigures figures;
  const double camera_z = first_camera_ ? first_camera_->translation.z() : 0.0;
  const bool has_floor = floor_ && floor_->found;
  mapper_.WithBuilder([&](OctoMapBuilder& builder) {
    const auto t_sync = Clock::now();
    builder.Finalize();  // the map of the final poses
    const double final_sync_ms =
        std::chrono::duration<double, std::milli>(Clock::now() - t_sync).count();
    figures.stats = builder.Stats();
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
    if (options_.reference_until) WriteReference(builder, &figures);
    std::printf("final map sync (rebuild after pose corrections): %.1f ms\n", final_sync_ms);
  });
  return figures;
}

int MapController::Run() {
  // A stop request ends the frame loop; the outputs are then written from what was processed
  // (shares the flag of dygslam main's early scope, so a signal during setup counts too).
  const StopFlag stop(StopFlag::Signals::kStop);
  if (!options_.given_poses) {
    system_.emplace(options_.system);
    system_->SetKeyframeCallback([this](const KeyframeData& k) { OnKeyframe(k); });
  }
  t0_ = last_save_ = Clock::now();
  auto stop_requested = [&stop] { return stop.requested(); };
  // Bad input found mid-run (an image that does not decode) ends the frame loop, but the map and
  // every output are written from the frames before it (as on a stop signal); then the error is
  // reported (exit 1).
  std::exception_ptr failure;
  try {
    if (options_.given_poses) {
      FeedGivenPoses(stop_requested);
    } else {
      FeedSlam(stop_requested);
    }
  } catch (const std::exception&) {
    failure = std::current_exception();
  }
  if (options_.progress) std::fprintf(stderr, "\n");
  if (system_) system_->Shutdown();  // last local-mapping corrections reach the mapper
  mapper_.Flush();
  const double elapsed = std::chrono::duration<double>(Clock::now() - t0_).count();
  RecreateOutputDirIfRemoved("map", "out", options_.out);
  if (system_) {
    RunOutputs outputs(options_.out, {"trajectory.txt", "keyframes.txt"});
    WriteRunRecord(outputs, RunRecordOfSystem(*system_));
    outputs.ThrowIfAnyFailed();
  }
  // SLAM maps: level the map by the floor it found, so pictures and planners see it upright.
  if (system_ && first_camera_) LevelMap();
  const MapFigures figures = WriteMaps();
  PrintSummary(figures, elapsed);
  if (failure) {
    std::fprintf(stderr,
                 "[map] stopped by an error after %zu frames: the map and outputs of those frames "
                 "are written to %s\n",
                 processed_, options_.out.string().c_str());
    std::rethrow_exception(failure);
  }
  // A SLAM map from (almost) no tracked frame is no map of the scene: fail, and say why.
  if (system_ && !interrupted_) {
    const size_t tracked = system_->Trajectory().size();
    if (IsTrackingFailure(processed_, tracked)) {
      PrintTrackingFailure("map", processed_, tracked, lost_);
      return 1;
    }
  }
  return 0;
}

void MapController::PrintKeyframeRate(const OctoMapStats& stats, const MapperStats& ms,
                                      double elapsed) const {
  if (keyframe_stamps_.size() >= 2) {
    const double span = SecondsBetween(keyframe_stamps_.front(), keyframe_stamps_.back());
    const double keyframe_rate = (keyframe_stamps_.size() - 1) / std::max(span, 1e-9);
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
        keyframe_rate, keyframe_stamps_.size(), span, capacity,
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
}

void MapController::PrintMapFrame() const {
  if (floor_) {
    const double camera_z = first_camera_ ? first_camera_->translation.z() : 0.0;
    if (floor_->found) {
      std::printf(
          "map frame: levelled on the floor (%zu cells, %.1f deg from the first camera's up); "
          "first camera %.2f m above it\n",
          floor_->num_inliers, floor_->tilt_from_prior_deg, camera_z);
    } else {
      std::printf(
          "map frame: no floor found; z = up in the first image, first camera at the origin\n");
    }
    const Eigen::Quaterniond q = map_from_world_.rotation;
    std::printf("map_from_slam_world (tx ty tz qx qy qz qw): %.6f %.6f %.6f %.6f %.6f %.6f %.6f\n",
                map_from_world_.translation.x(), map_from_world_.translation.y(),
                map_from_world_.translation.z(), q.x(), q.y(), q.z(), q.w());
  }
}

void MapController::PrintSummary(const MapFigures& figures, double elapsed) {
  const MapControllerOptions& o = options_;
  const OctoMapStats& stats = figures.stats;
  const MapperStats ms = mapper_.Stats();
  if (interrupted_) {
    std::printf(
        "interrupted by a signal after %zu of %zu frames: map and outputs written from them\n",
        processed_, o.last - o.first);
  }
  if (system_) {
    std::printf(
        "frames: %zu processed, %zu lost, %zu without depth partner; %.1f fps (SLAM + map)\n",
        processed_, lost_, skipped_, processed_ / std::max(elapsed, 1e-9));
    std::printf("filter: %s%s; map masks %s\n", ToString(o.system.filter.mode),
                o.system.deterministic ? " (deterministic)" : "",
                o.octomap.use_dynamic_mask ? "applied" : "not applied");
  } else {
    std::printf("frames: %zu inserted from %s (every %d), %zu without pose\n", processed_,
                EchoValue(o.trajectory_path).c_str(), o.every, lost_);
  }
  std::printf(
      "keyframes: %zu in the map (%zu inserted, %zu pose corrections, %zu culled), %llu rebuilds\n",
      stats.num_keyframes, ms.num_new_keyframes, ms.num_pose_updates + ms.num_coalesced,
      ms.num_removals, static_cast<unsigned long long>(stats.num_rebuilds));
  std::printf(
      "map: resolution %.3f m, %zu leaves (%zu occupied, %zu free), %s occupied / %s free cells, "
      "%.2f MB\n",
      o.octomap.resolution, stats.num_leaves, stats.num_occupied_leaves, stats.num_free_leaves,
      Count(stats.num_occupied_voxels).c_str(), Count(stats.num_free_voxels).c_str(),
      stats.memory_bytes / 1048576.0);
  std::printf(
      "insertion per keyframe: median %.1f ms wall, %.1f ms CPU; last rebuild %.1f ms wall, %.1f "
      "ms CPU for "
      "%zu keyframes\n",
      stats.median_insert_ms, stats.median_insert_cpu_ms, stats.last_rebuild_ms,
      stats.last_rebuild_cpu_ms, stats.num_keyframes);
  PrintKeyframeRate(stats, ms, elapsed);
  PrintMapFrame();
  if (figures.ghosts) {
    const GhostVoxelCounts& ghosts = *figures.ghosts;
    std::printf("reference: %zu keyframes before rgb entry %s\n", figures.reference_keyframes,
                EchoValue(o.reference_name).c_str());
    std::printf(
        "ghost voxels: %s (occupied in the map, observed free in the reference, no reference "
        "surface "
        "within 1 cell); occupied-and-free %s; map occupied %s, reference occupied %s\n",
        Count(ghosts.ghost).c_str(), Count(ghosts.occupied_a_free_b).c_str(),
        Count(ghosts.occupied_in_a).c_str(), Count(ghosts.occupied_in_b).c_str());
  }
  if (saves_ > 0) std::printf("periodic saves: %zu\n", saves_);
  std::printf("outputs: %s/{map.bt,map.ot,map_top.png,map_slice.png%s%s}\n", o.out.string().c_str(),
              system_ ? ",trajectory.txt,keyframes.txt" : "",
              figures.ghosts ? ",reference.bt,ghosts_top.png,ghost_cells.txt" : "");
}

}  // namespace dygslam
