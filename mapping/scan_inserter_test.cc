#include "mapping/scan_inserter.h"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <random>
#include <sstream>
#include <string>

namespace dygslam {
namespace {

// The whole tree with its probabilities (.ot stream): equal strings = the same nodes and values.
std::string FullStream(octomap::OcTree& tree) {
  std::ostringstream out;
  tree.write(out);
  return out.str();
}

// A room-like scan: points at 1-6 m (some beyond max_range), a blob of points in one cell that
// stays put while the sensor moves (it saturates), and a point on the sensor's own cell.
octomap::Pointcloud MakeScan(std::mt19937& rng, const octomap::point3d& origin) {
  std::uniform_real_distribution<float> unit(-1.f, 1.f);
  std::uniform_real_distribution<float> range(1.f, 6.f);
  octomap::Pointcloud scan;
  for (int i = 0; i < 3000; ++i) {
    octomap::point3d direction(unit(rng), unit(rng), 0.3f * unit(rng) + 1.f);
    direction.normalize();
    scan.push_back(origin + direction * range(rng));
  }
  for (int i = 0; i < 50; ++i) scan.push_back(octomap::point3d(1.01f, 0.51f, 2.02f));
  scan.push_back(origin);
  return scan;
}

TEST(ScanInserter, SameTreeAsInsertPointCloud) {
  std::mt19937 rng(7);
  for (const bool lazy_eval : {true, false}) {
    octomap::OcTree expected(0.05);
    octomap::OcTree actual(0.05);
    ScanInserter inserter;
    // Overlapping scans from a moving sensor (cells seen free, then occupied, then free again;
    // cells clamped at either end; a pruned tree in between, whose leaves get expanded).
    for (int k = 0; k < 10; ++k) {
      const octomap::point3d origin(0.1f * k, -0.03f * k, 0.02f * k);
      const octomap::Pointcloud scan = MakeScan(rng, origin);
      expected.insertPointCloud(scan, origin, 4.0, lazy_eval, false);
      inserter.Insert(actual, scan, origin, 4.0, lazy_eval);
      if (k == 3 || k == 7) {
        expected.updateInnerOccupancy();
        expected.prune();
        actual.updateInnerOccupancy();
        actual.prune();
      }
    }
    EXPECT_EQ(inserter.grid_scans(), 10);
    EXPECT_EQ(inserter.fallback_scans(), 0);
    expected.updateInnerOccupancy();
    actual.updateInnerOccupancy();
    EXPECT_GT(actual.getNumLeafNodes(), 10000u);
    EXPECT_EQ(actual.size(), expected.size());
    EXPECT_EQ(FullStream(actual), FullStream(expected)) << "lazy_eval " << lazy_eval;
  }
}

TEST(ScanInserter, FallsBackWhereTheGridDoesNotReach) {
  std::mt19937 rng(11);
  const octomap::point3d origin(0.2f, 0.1f, -0.3f);
  const octomap::Pointcloud scan = MakeScan(rng, origin);
  // 20 m at 5 cm is more than kMaxHalfSideCells each way: insertPointCloud does the scan.
  octomap::OcTree expected(0.05), actual(0.05);
  ScanInserter inserter;
  expected.insertPointCloud(scan, origin, 20.0, true, false);
  inserter.Insert(actual, scan, origin, 20.0, true);
  EXPECT_EQ(inserter.fallback_scans(), 1);
  EXPECT_EQ(FullStream(actual), FullStream(expected));
  // A bounding box on the tree: insertPointCloud's own clipping applies.
  octomap::OcTree boxed_expected(0.05), boxed_actual(0.05);
  octomap::point3d box_min(-1, -1, -1), box_max(1, 1, 3);  // (setBBXMin takes a reference)
  for (octomap::OcTree* tree : {&boxed_expected, &boxed_actual}) {
    tree->setBBXMin(box_min);
    tree->setBBXMax(box_max);
    tree->useBBXLimit(true);
  }
  boxed_expected.insertPointCloud(scan, origin, 4.0, true, false);
  inserter.Insert(boxed_actual, scan, origin, 4.0, true);
  EXPECT_EQ(inserter.fallback_scans(), 2);
  EXPECT_EQ(FullStream(boxed_actual), FullStream(boxed_expected));
  // The grid is clean after a fallback: the next scan through it matches again.
  octomap::OcTree after_expected(0.05), after_actual(0.05);
  after_expected.insertPointCloud(scan, origin, 4.0, true, false);
  inserter.Insert(after_actual, scan, origin, 4.0, true);
  EXPECT_EQ(inserter.grid_scans(), 1);
  EXPECT_EQ(FullStream(after_actual), FullStream(after_expected));
}

}  // namespace
}  // namespace dygslam
