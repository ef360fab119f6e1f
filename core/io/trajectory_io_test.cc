#include "core/io/trajectory_io.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "core/base/error.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

std::string WriteText(const std::string& name, const std::string& text) {
  const fs::path p = fs::path(testing::MakeTempDir("io_traj")) / name;
  std::ofstream(p) << text;
  return p.string();
}

void ExpectError(const std::string& text, const std::string& needle) {
  const std::string path = WriteText("t.txt", text);
  try {
    ReadTumTrajectory(path);
    ADD_FAILURE() << "expected InputError containing " << needle;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TEST(TrajectoryIo, RoundTripKeepsValuesAndStamps) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0, 3);
  std::vector<StampedPose> poses;
  for (int i = 0; i < 50; ++i) {
    StampedPose p;
    // Mix of microsecond and nanosecond stamps.
    p.stamp = Timestamp::FromNanoseconds(1548339823'898123000LL + i * 33'366'667LL + (i % 3));
    p.world_from_cam = Rigid3d(Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized(),
                               Eigen::Vector3d(n(rng), n(rng), n(rng)));
    poses.push_back(p);
  }
  const std::string dir = testing::MakeTempDir("io_traj");
  const std::string path = dir + "/traj.txt";
  WriteTumTrajectory(path, poses);
  EXPECT_FALSE(fs::exists(path + ".tmp." + std::to_string(::getpid())));
  const std::vector<StampedPose> back = ReadTumTrajectory(path);
  ASSERT_EQ(back.size(), poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    EXPECT_EQ(back[i].stamp, poses[i].stamp);
    EXPECT_LT((back[i].world_from_cam.translation - poses[i].world_from_cam.translation).norm(),
              1e-9);
    EXPECT_LT(back[i].world_from_cam.rotation.angularDistance(poses[i].world_from_cam.rotation),
              1e-9);
  }
  // Every data line has exactly 8 columns.
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line[0] == '#') continue;
    std::istringstream s(line);
    std::string tok;
    int cols = 0;
    while (s >> tok) ++cols;
    EXPECT_EQ(cols, 8) << line;
  }
}

TEST(TrajectoryIo, ReadsTumStyleWithCommentsBlankLinesAndCrLf) {
  const std::string path = WriteText(
      "gt.txt",
      "# ground truth\n\n1305031102.175304 1.3405 0.6266 1.6575 0.6574 0.6126 -0.2949 -0.3248\r\n"
      "1305031102.211214\t1.3303 0.6256 1.6464 0.6579 0.6161 -0.2932 -0.3189\n");
  const auto poses = ReadTumTrajectory(path);
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_EQ(poses[0].stamp.nanoseconds(), 1305031102175304000LL);
  EXPECT_DOUBLE_EQ(poses[1].world_from_cam.translation.z(), 1.6464);
  EXPECT_NEAR(poses[0].world_from_cam.rotation.w(), -0.3248, 1e-3);
}

// A number too close to zero for a double is finite: it reads as what it rounds to.
TEST(TrajectoryIo, ANumberTooSmallForADoubleReadsAsItsRounding) {
  const std::string path = (std::filesystem::path(::testing::TempDir()) / "tiny.txt").string();
  std::ofstream(path) << "1.0 0 0 0 0 0 0 1\n2.0 1e-400 -1e-320 0 0 0 0 1\n";
  const std::vector<StampedPose> poses = ReadTumTrajectory(path);
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_EQ(poses[1].world_from_cam.translation.x(), 0.0);
  EXPECT_LE(std::abs(poses[1].world_from_cam.translation.y()), 1e-300);
}

TEST(TrajectoryIo, BadInputNamesFileAndLine) {
  const std::string ok = "1.0 0 0 0 0 0 0 1\n";
  ExpectError(ok + "2.0 0 0 0 0 0 1\n", ":2: expected 8 columns");
  ExpectError(ok + "2.0 0 0 0 0 0 0 1 5\n", ":2: expected 8 columns");
  ExpectError(ok + "x 0 0 0 0 0 0 1\n", ":2: malformed timestamp");
  ExpectError(ok + "2.0 0 abc 0 0 0 0 1\n", ":2: column 3: not a number");
  ExpectError(ok + "2.0 0x10 0 0 0 0 0 1\n", ":2: column 2: not a number: '0x10'");
  ExpectError(ok + "2.0 0 0 nan 0 0 0 1\n", ":2: column 4: non-finite");
  ExpectError(ok + "2.0 0 0 inf 0 0 0 1\n", ":2: column 4: non-finite");
  ExpectError(ok + "2.0 0 0 1e400 0 0 0 1\n", ":2: column 4: value out of range (beyond a double)");
  ExpectError(ok + "2.0 0 0 -1e400 0 0 0 1\n", ":2: column 4: value out of range");
  ExpectError(ok + "2.0 0 0 0 0 0 0 2\n", ":2: quaternion is not unit length");
  ExpectError(ok + "2.0 0 -1e30 0 0 0 0 1\n",
              ":2: column 3: coordinate -1e+30 m is beyond 1e+07 m");
  ExpectError(ok + "0.5 0 0 0 0 0 0 1\n", ":2: timestamps not sorted");
  ExpectError(ok + ok, ":2: duplicate timestamp");
  EXPECT_THROW(ReadTumTrajectory("/nonexistent/traj.txt"), InputError);
}

// A trajectory whose poses are kilometres beyond any camera is no input to evaluate, yet it is a
// TUM trajectory file (the output of a run with a wrong depth scale, for the next run to replace);
// text that is not one is neither.
TEST(TrajectoryIo, FarPosesAreATumFileButNoTrajectoryToRead) {
  const std::string far = WriteText("far.txt", "1.0 5e10 0 0 0 0 0 1\n2.0 6e10 0 0 0 0 0 1\n");
  EXPECT_TRUE(IsTumTrajectoryFile(far));
  EXPECT_THROW(ReadTumTrajectory(far), InputError);
  EXPECT_FALSE(IsTumTrajectoryFile(WriteText("notes.txt", "my notes\n")));
  EXPECT_FALSE(IsTumTrajectoryFile(WriteText("hex.txt", "1.0 0x10 0 0 0 0 0 1\n")));
}

TEST(TrajectoryIo, WriteRefusesBadPosesAndMissingDirectory) {
  std::vector<StampedPose> poses(2);
  poses[0].stamp = Timestamp::FromSeconds(1.0);
  poses[1].stamp = Timestamp::FromSeconds(2.0);
  EXPECT_THROW(WriteTumTrajectory("/nonexistent_dir_xyz/t.txt", poses), InputError);
  const std::string dir = testing::MakeTempDir("io_traj");
  poses[1].world_from_cam.translation.x() = std::nan("");
  EXPECT_THROW(WriteTumTrajectory(dir + "/t.txt", poses), InputError);
  EXPECT_FALSE(fs::exists(dir + "/t.txt"));
  poses[1].world_from_cam.translation.x() = 0;
  poses[1].stamp = poses[0].stamp;
  EXPECT_THROW(WriteTumTrajectory(dir + "/t.txt", poses), InputError);
}

TEST(TrajectoryIo, ReadsRealGroundTruth) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const auto gt = ReadTumTrajectory(dir + "/groundtruth.txt");
  EXPECT_GT(gt.size(), 300u);
  EXPECT_EQ(gt.front().stamp.ToString(), "1548339823.861200");
}

}  // namespace
}  // namespace dygslam
