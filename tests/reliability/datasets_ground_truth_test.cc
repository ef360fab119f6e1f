// A malformed groundtruth.txt is found before the first frame: a warning naming file:line, and the
// run goes on without evaluation (--direct and --processes; DDS domain 156 in the netns emulator).
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

class GroundTruthFiles : public testing::CliFixture {
 protected:
  GroundTruthFiles() : CliFixture("datasets_ground_truth") {}
};

// A malformed groundtruth.txt was found only after the run (exit 1 then). It is found before
// the first frame: a warning naming file:line, and the run goes on without evaluation.
TEST_F(GroundTruthFiles, MalformedGroundTruthWarnsUpFrontAndTheRunGoesOn) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string dataset = SmallDataset(source, 20, "gt");
  std::ofstream(dataset + "/groundtruth.txt")
      << "# ground truth\n1548339822.0 0 0 0 0 0 0 1\n1548339822.1 0 zero 0 0 0 0 1\n";
  for (const char* mode : {"--direct", "--processes"}) {
    const std::string out = dir_ + "/gt_out_" + std::string(mode + 2);
    const auto r = Run({"run", dataset, "--config", Config(), "--out", out, "--filter", "none",
                        "--domain", "156", mode});
    EXPECT_EQ(r.code, 0) << mode << "\n" << r.err;
    const std::string warning = "warning: " + dataset + "/groundtruth.txt:3:";
    EXPECT_TRUE(Contains(r.err, warning)) << mode << "\n" << r.err;
    EXPECT_TRUE(Contains(r.err, "goes on without evaluation")) << r.err;
    EXPECT_TRUE(Contains(r.out, "ATE: not evaluated")) << r.out;
    EXPECT_GE(ReadTumTrajectory(out + "/trajectory.txt").size(), 18u) << mode;
    if (std::string(mode) == "--direct") {
      // Before the first frame: the warning precedes the progress line.
      EXPECT_LT(r.err.find(warning), r.err.find("[run] frame")) << r.err;
    }
  }
}

}  // namespace
}  // namespace dygslam
