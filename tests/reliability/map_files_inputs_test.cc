// Map inputs of `dygslam run`: --load-octomap given a FIFO or a folder is refused at once; a
// localization run that adds no keyframe writes the loaded map's static map as map.bt, and
// --save-map writes map.ot beside map.bt.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <sys/stat.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "mapping/octomap_builder.h"
#include "tests/support/cli_fixture.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

using testing::Contains;
using testing::ReadAll;

class MapFileInputs : public testing::CliFixture {
 protected:
  MapFileInputs() : CliFixture("map_files_inputs") {}
};

// --load-octomap given a FIFO blocked forever; binary inputs must be regular files.
TEST_F(MapFileInputs, BinaryInputThatIsAFifoIsRefusedAtOnce) {
  const std::string fifo = dir_ + "/map.ot";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const auto r = RunWithin({"run", dir_, "--config", Config(), "--out", dir_ + "/out", "--direct",
                            "--load-octomap", fifo},
                           20);
  ExpectError(r, 1, {"--load-octomap", fifo, "not a regular file"});
  // The same for a folder.
  ExpectError(RunWithin({"run", dir_, "--config", Config(), "--out", dir_ + "/out", "--direct",
                         "--load-octomap", dir_},
                        20),
              1, {"--load-octomap", "not a regular file"});
}

// A --load-map --localization run adds no keyframe, so the mapper had nothing to insert
// and no map.bt was written; it is now the loaded map's static map (its map points).
TEST_F(MapFileInputs, LocalizationRunWritesTheLoadedMapsStaticMap) {
  DYGSLAM_REQUIRE_DATASET(data, "bonn_crowd_part");
  const std::string map_file = dir_ + "/slam.map";
  const auto saved =
      Run({"run", data, "--config", Config(), "--frames", "0:20", "--direct", "--filter", "none",
           "--quiet", "--no-map", "--out", dir_ + "/first", "--save-map", map_file});
  ASSERT_EQ(saved.code, 0) << saved.err;
  const auto r =
      Run({"run", data, "--config", Config(), "--frames", "0:20", "--direct", "--filter", "none",
           "--quiet", "--out", dir_ + "/second", "--load-map", map_file, "--localization"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(Contains(r.out, "map.bt: the static map of " + map_file)) << r.out;
  ASSERT_TRUE(fs::exists(dir_ + "/second/map.bt")) << r.out;
  // A real OctoMap: occupied voxels where the map points are, free space before them.
  const auto tree = ReadOctoMap(dir_ + "/second/map.bt");
  size_t occupied = 0, free = 0;
  for (auto it = tree->begin_leafs(); it != tree->end_leafs(); ++it)
    (tree->isNodeOccupied(*it) ? occupied : free) += 1;
  EXPECT_GT(occupied, 100u);
  EXPECT_GT(free, occupied);
  EXPECT_FALSE(fs::exists(dir_ + "/second/map.ot"));  // no --save-map
  // With --save-map the run writes map.ot beside map.bt, as the README says (it did not).
  const auto saving = Run({"run", data, "--config", Config(), "--frames", "0:20", "--direct",
                           "--filter", "none", "--quiet", "--out", dir_ + "/third", "--load-map",
                           map_file, "--localization", "--save-map", dir_ + "/again.map"});
  ASSERT_EQ(saving.code, 0) << saving.err;
  EXPECT_TRUE(fs::exists(dir_ + "/third/map.bt"));
  EXPECT_GT(ReadOctoMap(dir_ + "/third/map.ot")->size(), 0u);
}

}  // namespace
}  // namespace dygslam
