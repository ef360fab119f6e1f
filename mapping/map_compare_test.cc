#include "mapping/map_compare.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "mapping/octomap_builder.h"
#include "tools/synth/box_room.h"

namespace dygslam {
namespace {

using box_room::Box;
using box_room::Scene;

TEST(MapCompare, CountsCellsOfHandMadeMaps) {
  octomap::OcTree a(0.1), b(0.1);
  // A: two occupied cells; B: one of them free, the other occupied; plus a cell only B knows.
  a.updateNode(octomap::point3d(0.05f, 0.05f, 0.05f), true);
  a.updateNode(octomap::point3d(0.55f, 0.05f, 0.05f), true);
  a.updateNode(octomap::point3d(1.05f, 0.05f, 0.05f), true);
  b.updateNode(octomap::point3d(0.05f, 0.05f, 0.05f), false);
  b.updateNode(octomap::point3d(0.55f, 0.05f, 0.05f), true);
  b.updateNode(octomap::point3d(2.05f, 0.05f, 0.05f), true);
  a.updateNode(octomap::point3d(2.05f, 0.05f, 0.05f), false);
  const GhostVoxelCounts c = CompareGhostVoxels(a, b);
  EXPECT_EQ(c.occupied_in_a, 3u);
  EXPECT_EQ(c.occupied_a_free_b, 1u);
  EXPECT_EQ(c.ghost, 1u);  // its nearest occupied B cell is 5 cells away
  EXPECT_EQ(c.occupied_a_occupied_b, 1u);
  EXPECT_EQ(c.occupied_a_unknown_b, 1u);
  EXPECT_EQ(c.occupied_in_b, 2u);
  EXPECT_EQ(c.occupied_b_free_a, 1u);
  EXPECT_NEAR(c.GhostFraction(), 1.0 / 3.0, 1e-12);

  EXPECT_EQ(CountOccupiedInside(a, [](const octomap::point3d& p) { return p.x() < 0.8; }), 2u);
  EXPECT_EQ(CountFreeInside(a, [](const octomap::point3d&) { return true; }), 1u);
  EXPECT_EQ(CellState(a, octomap::point3d(0.55f, 0.05f, 0.05f)), 1);
  EXPECT_EQ(CellState(a, octomap::point3d(2.05f, 0.05f, 0.05f)), 0);
  EXPECT_EQ(CellState(a, octomap::point3d(5.05f, 0.05f, 0.05f)), -1);

  // A free B cell next to an occupied B cell is surface jitter, not a ghost.
  b.updateNode(octomap::point3d(0.15f, 0.05f, 0.05f), true);
  b.updateNode(octomap::point3d(0.05f, 0.05f, 0.05f), false);
  const GhostVoxelCounts near = CompareGhostVoxels(a, b);
  EXPECT_EQ(near.occupied_a_free_b, 1u);
  EXPECT_EQ(near.ghost, 0u);
  EXPECT_EQ(CompareGhostVoxels(a, b, 0).ghost, 1u);
  EXPECT_THROW(CompareGhostVoxels(a, b, -1), std::invalid_argument);

  octomap::OcTree coarse(0.2);
  EXPECT_THROW(CompareGhostVoxels(a, coarse), std::invalid_argument);
}

TEST(MapCompare, PrunedLeavesCountAsAllTheirCells) {
  octomap::OcTree a(0.1), b(0.1);
  // Fill a 2x2x2 block aligned to the grid: it prunes into one leaf of 8 cells.
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      for (int k = 0; k < 2; ++k) {
        const octomap::point3d p(0.05f + 0.1f * i, 0.05f + 0.1f * j, 0.05f + 0.1f * k);
        for (int n = 0; n < 10; ++n) a.updateNode(p, true);  // saturate: identical values
        b.updateNode(p, false);
      }
  a.prune();
  size_t leaves = 0;
  for (auto it = a.begin_leafs(); it != a.end_leafs(); ++it) ++leaves;
  ASSERT_EQ(leaves, 1u);
  const GhostVoxelCounts c = CompareGhostVoxels(a, b);
  EXPECT_EQ(c.occupied_in_a, 8u);
  EXPECT_EQ(c.occupied_a_free_b, 8u);
  EXPECT_EQ(CountOccupiedInside(a, [](const octomap::point3d& p) { return p.z() < 0.1; }), 4u);
}

// Ghosts of a walking person: the map from all frames (mask ignored) against a reference from
// the same poses with nobody in the room. With the mask, the person's ghosts are gone.
TEST(MapCompare, GhostVoxelsOfAWalkingPerson) {
  const PinholeCamera camera = box_room::SmallCamera();
  OctoMapOptions options;
  options.pixel_stride = 1;
  OctoMapBuilder reference(camera, options), masked(camera, options);
  options.use_dynamic_mask = false;
  OctoMapBuilder unmasked(camera, options);
  for (int k = 0; k < 30; ++k) {
    const Rigid3d pose = box_room::LookingAlong({-1.2, 0, 1.2}, 0.2 * std::sin(0.3 * k));
    Scene empty = box_room::DefaultRoom();
    Scene with_person = empty;
    const double y = -1.0 + 0.07 * k;
    with_person.dynamic_boxes.push_back({{0.31, y - 0.2, -0.02}, {0.71, y + 0.2, 1.68}});
    reference.Insert(box_room::MakeKeyframe(k, empty, camera, pose));
    masked.Insert(box_room::MakeKeyframe(k, with_person, camera, pose));
    unmasked.Insert(box_room::MakeKeyframe(k, with_person, camera, pose));
  }
  const GhostVoxelCounts none = CompareGhostVoxels(reference.tree(), reference.tree());
  EXPECT_EQ(none.occupied_a_free_b, 0u);
  EXPECT_EQ(none.occupied_a_occupied_b, none.occupied_in_a);

  const GhostVoxelCounts raw = CompareGhostVoxels(unmasked.tree(), reference.tree());
  const GhostVoxelCounts filtered = CompareGhostVoxels(masked.tree(), reference.tree());
  EXPECT_GT(raw.ghost, 50u);
  EXPECT_LT(filtered.occupied_a_free_b * 20, raw.occupied_a_free_b)
      << "filtered " << filtered.occupied_a_free_b << " raw " << raw.occupied_a_free_b;
  EXPECT_LT(filtered.ghost * 20, raw.ghost);  // a few edge cells at most
  EXPECT_GT(filtered.occupied_a_occupied_b, filtered.occupied_in_a * 9 / 10);
}

}  // namespace
}  // namespace dygslam
