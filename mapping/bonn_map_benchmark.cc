// Mapping figures on the shared Bonn frames, with ground-truth poses and no dynamic mask:
//   dygslam_mapping_benchmark [DATASET_DIR] [--resolution R] [--every N] [--out DIR]
//                             [--pixel-stride N] [--check-marker] [--raw-gt]
// Prints insertion time per keyframe (median), map memory and leaf counts for a people-free
// reference map (frames 0-99) and a map from all frames, and the ghost-voxel counts between
// them. Camera poses are ground truth * BonnMarkerFromCam() (--raw-gt: the body pose as the
// camera pose). --check-marker compares the 24 axis-aligned rotations between the ground-truth body
// frame and the camera frame by how consistently frames 50-99 fall onto the map of frames 0-49.
#include <octomap/OcTree.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/io/bonn.h"
#include "mapping/map_compare.h"
#include "mapping/map_render.h"
#include "mapping/octomap_builder.h"

namespace dygslam {
namespace {

struct Frame {
  KeyframeData keyframe;
  Rigid3d gt;
};

std::vector<Frame> LoadFrames(const std::string& dir, int every) {
  std::vector<Frame> frames;
  for (GroundTruthDepthFrame& g : LoadGroundTruthDepthFrames(dir, every)) {
    Frame f;
    f.keyframe.id = static_cast<int64_t>(g.index);
    f.keyframe.stamp = g.stamp;
    f.keyframe.depth = std::move(g.depth);
    f.gt = g.world_from_body;
    frames.push_back(std::move(f));
  }
  return frames;
}

std::vector<Eigen::Matrix3d> AxisRotations() {
  std::vector<Eigen::Matrix3d> out;
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (const auto& p : perms) {
    for (int signs = 0; signs < 8; ++signs) {
      Eigen::Matrix3d r = Eigen::Matrix3d::Zero();
      for (int c = 0; c < 3; ++c) r(p[c], c) = (signs >> c & 1) ? -1 : 1;
      if (r.determinant() > 0) out.push_back(r);
    }
  }
  return out;
}

void CheckMarker(const std::vector<Frame>& frames, const PinholeCamera& camera) {
  OctoMapOptions options;
  options.resolution = 0.05;
  options.use_dynamic_mask = false;
  std::printf("marker_from_cam candidate (rows)        consistency  occupied_cells\n");
  std::vector<Rigid3d> candidates = {BonnMarkerFromCam()};
  if (std::getenv("DYGSLAM_MARKER_ALL_AXES") != nullptr) {
    for (const Eigen::Matrix3d& r : AxisRotations())
      candidates.emplace_back(r, Eigen::Vector3d::Zero());
  } else {
    candidates.push_back(Rigid3d());
  }
  for (const Rigid3d& marker_from_cam : candidates) {
    const Eigen::Matrix3d r = marker_from_cam.RotationMatrix();
    OctoMapBuilder builder(camera, options);
    size_t hits = 0, total = 0;
    for (const Frame& f : frames) {
      if (f.keyframe.id >= 100) break;
      KeyframeData kf = f.keyframe;
      kf.world_from_cam = f.gt * marker_from_cam;
      if (kf.id < 50) {
        builder.Insert(kf);
        continue;
      }
      const octomap::OcTree& tree = builder.tree();
      for (const Eigen::Vector3f& p : builder.ExtractStaticCloud(kf).points_cam) {
        const Eigen::Vector3d w = kf.world_from_cam * p.cast<double>();
        ++total;
        hits += CellState(tree, octomap::point3d(w.x(), w.y(), w.z())) == 1;
      }
    }
    std::printf("[%2.0f %2.0f %2.0f; %2.0f %2.0f %2.0f; %2.0f %2.0f %2.0f]   %.3f       %llu\n",
                r(0, 0), r(0, 1), r(0, 2), r(1, 0), r(1, 1), r(1, 2), r(2, 0), r(2, 1), r(2, 2),
                total ? double(hits) / total : 0.0,
                static_cast<unsigned long long>(builder.Stats().num_occupied_voxels));
  }
}

int Main(int argc, char** argv) {
  std::string dir;
  std::string out_dir;
  double resolution = 0.05;
  int every = 1;
  bool check_marker = false;
  bool raw_gt = false;
  int pixel_stride = OctoMapOptions().pixel_stride;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--resolution" && i + 1 < argc) {
      resolution = std::atof(argv[++i]);
    } else if (arg == "--every" && i + 1 < argc) {
      every = std::max(1, std::atoi(argv[++i]));
    } else if (arg == "--out" && i + 1 < argc) {
      out_dir = argv[++i];
    } else if (arg == "--pixel-stride" && i + 1 < argc) {
      pixel_stride = std::atoi(argv[++i]);
    } else if (arg == "--raw-gt") {
      raw_gt = true;
    } else if (arg == "--check-marker") {
      check_marker = true;
    } else {
      dir = arg;
    }
  }
  if (dir.empty()) dir = "/work/shared/data/bonn_crowd_part";
  const PinholeCamera camera = BonnCamera();
  const std::vector<Frame> frames = LoadFrames(dir, every);
  std::printf("%zu frames with ground truth (every %d)\n", frames.size(), every);
  if (check_marker) {
    CheckMarker(frames, camera);
    return 0;
  }

  OctoMapOptions options;
  options.resolution = resolution;
  options.use_dynamic_mask = false;
  options.pixel_stride = pixel_stride;
  OctoMapBuilder reference(camera, options), all(camera, options);
  for (const Frame& f : frames) {
    KeyframeData kf = f.keyframe;
    kf.world_from_cam = raw_gt ? f.gt : f.gt * BonnMarkerFromCam();
    if (kf.id < 100) reference.Insert(kf);
    all.Insert(kf);
  }
  const auto t0 = std::chrono::steady_clock::now();
  all.Sync();
  const double sync_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  for (auto* b : {&reference, &all}) {
    const OctoMapStats s = b->Stats();
    std::printf(
        "%s: keyframes %zu, stored points %zu, leaves %zu (occupied %zu, free %zu), occupied "
        "cells %llu, memory %.2f MB, insert median %.1f ms/keyframe\n",
        b == &reference ? "reference 0-99" : "all frames", s.num_keyframes, s.num_stored_points,
        s.num_leaves, s.num_occupied_leaves, s.num_free_leaves,
        static_cast<unsigned long long>(s.num_occupied_voxels), s.memory_bytes / 1e6,
        s.median_insert_ms);
  }
  std::printf("final inner-node update + prune: %.1f ms\n", sync_ms);
  const GhostVoxelCounts c = CompareGhostVoxels(all.tree(), reference.tree());
  std::printf(
      "ghost cells (occupied in all-frames map, observed free in reference, no reference "
      "surface within 1 cell): %llu of %llu occupied (%.1f %%); occupied-and-free incl. surface "
      "jitter %llu; agreed %llu, unknown in reference %llu; reference cells cleared in "
      "all-frames map: %llu of %llu\n",
      static_cast<unsigned long long>(c.ghost), static_cast<unsigned long long>(c.occupied_in_a),
      100.0 * c.GhostFraction(), static_cast<unsigned long long>(c.occupied_a_free_b),
      static_cast<unsigned long long>(c.occupied_a_occupied_b),
      static_cast<unsigned long long>(c.occupied_a_unknown_b),
      static_cast<unsigned long long>(c.occupied_b_free_a),
      static_cast<unsigned long long>(c.occupied_in_b));
  const auto start = std::chrono::steady_clock::now();
  // Time a full rebuild (a 10 cm correction of the first keyframe), then undo it so the
  // written map is the ground-truth one.
  const int64_t first_id = frames.front().keyframe.id;
  const Rigid3d first_pose = all.Pose(first_id);
  all.UpdatePoses({{first_id, Rigid3d(first_pose.rotation,
                                      first_pose.translation + Eigen::Vector3d(0.1, 0, 0))}});
  all.Sync();
  std::printf(
      "full rebuild of %zu keyframes: %.0f ms\n", all.Stats().num_keyframes,
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  all.UpdatePoses({{first_id, first_pose}});
  if (!out_dir.empty()) {
    reference.WriteBinary(out_dir + "/reference.bt");
    all.WriteBinary(out_dir + "/all.bt");
    all.WriteFull(out_dir + "/all.ot");
    TopViewOptions top;
    WritePngAtomically(out_dir + "/reference_top.png", RenderTopView(reference.tree(), top));
    WritePngAtomically(out_dir + "/all_top.png", RenderTopView(all.tree(), top));
    WritePngAtomically(out_dir + "/all_slice_1m.png", RenderSlice(all.tree(), 1.0));
  }
  return 0;
}

}  // namespace
}  // namespace dygslam

int main(int argc, char** argv) {
  try {
    return dygslam::Main(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
