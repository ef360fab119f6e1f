// Dataset files through the command line: a groundtruth.txt that is a FIFO, a folder or a link to
// /dev/zero, a depth.txt cut short, an rgb.txt or groundtruth.txt cut at a line boundary and
// --frames beyond the dataset are warned; --detections that
// match no frame are warned, a class_id outside the detector's classes is an error.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/base/stop_signal.h"
#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "tests/support/cli_fixture.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

using testing::Contains;

class DatasetCli : public testing::CliFixture {
 protected:
  DatasetCli() : CliFixture("datasets_cli") {}

  // Replaces rgb.txt entry `entry`'s image by a truncated copy named broken.png.
  void BreakImage(const std::string& dataset, size_t entry) {
    const RgbdDataset d = RgbdDataset::Open(dataset);
    const std::string bytes = testing::ReadAll(d.frame(entry).rgb_path);
    std::ofstream(dataset + "/broken.png", std::ios::binary) << bytes.substr(0, bytes.size() / 3);
    std::string rgb = testing::ReadAll(dataset + "/rgb.txt");
    const std::string old_path = d.frame(entry).rgb_path;
    rgb.replace(rgb.find(old_path), old_path.size(), "broken.png");
    std::ofstream(dataset + "/rgb.txt") << rgb;
  }
};

// A groundtruth.txt that is not a regular file warns like a malformed one; a
// --frames beyond the dataset warns naming --frames and the real count.
TEST_F(DatasetCli, NonRegularGroundTruthAndFramesBeyondTheDatasetWarn) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  struct Kind {
    std::string name, reason;
  };
  for (const Kind& kind : std::vector<Kind>{{"fifo", "a FIFO"},
                                            {"folder", "a directory"},
                                            {"zero", "a character device (a link to /dev/zero)"}}) {
    const std::string dataset = SmallDataset(source, 12, "gt_" + kind.name);
    const std::string gt = dataset + "/groundtruth.txt";
    if (kind.name == "fifo") ASSERT_EQ(mkfifo(gt.c_str(), 0600), 0);
    if (kind.name == "folder") fs::create_directories(gt);
    if (kind.name == "zero") fs::create_symlink("/dev/zero", gt);
    const auto r = Run({"run", dataset, "--config", Config(), "--out", dir_ + "/o_" + kind.name,
                        "--filter", "none", "--direct", "--quiet", "--frames", "0:5000"});
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(Contains(r.err, "warning: " + gt + ": not a regular file: " + kind.reason))
        << r.err;
    EXPECT_TRUE(Contains(r.err, "without evaluation")) << r.err;
    EXPECT_TRUE(Contains(r.out, "ATE: not evaluated")) << r.out;
    EXPECT_TRUE(Contains(r.err, "warning: --frames '0:5000'")) << r.err;
    EXPECT_TRUE(Contains(r.err, "12 rgb.txt entries")) << r.err;
  }
}

// A depth.txt cut short at a line boundary (every line well-formed) leaves the last rgb.txt
// entries without a depth image: said before the run and in the summary's integrity line, so the
// run cannot read as a complete run of the whole range; eval.json counts them.
TEST_F(DatasetCli, ADepthListCutShortIsSaidBeforeAndAfterTheRun) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string dataset = SmallDataset(source, 20, "depth_cut", true);
  std::istringstream lines(testing::ReadAll(dataset + "/depth.txt"));
  std::string kept, line;
  int entries = 0;
  while (std::getline(lines, line)) {
    const bool entry = !line.empty() && line[0] != '#';
    if (entry && entries == 14) break;
    entries += entry ? 1 : 0;
    kept += line + "\n";
  }
  std::ofstream(dataset + "/depth.txt") << kept;
  const auto r = Run({"run", dataset, "--config", Config(), "--out", dir_ + "/o_cut", "--filter",
                      "none", "--direct", "--quiet"});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(Contains(r.err, "warning: 6 of the 20 rgb.txt entries 0 to 20 have no depth image"))
      << r.err;
  EXPECT_TRUE(Contains(r.out,
                       "integrity: 14 of 14 requested frames processed (complete; 6 rgb.txt "
                       "entries of the range left out: no depth image to pair with)"))
      << r.out;
  EXPECT_TRUE(Contains(testing::ReadAll(dir_ + "/o_cut/eval.json"),
                       "\"requested\": 14, \"without_depth_partner\": 6,"));
}

// A detections file that matches no frame warns with the counts; a class id outside the
// detector's classes is an error with file:line.
TEST_F(DatasetCli, DetectionsThatMatchNoFrameWarnAndBadClassIdsFail) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  DYGSLAM_REQUIRE_MODELS(models);
  const std::string dataset = SmallDataset(source, 10, "det");
  const std::string det = dir_ + "/det.txt";
  std::ofstream(det) << "99.0 10 10 50 50 0 0.9\n99.1 10 10 50 50 0 0.9\n";
  const auto r = Run({"run", dataset, "--config", Config(), "--out", dir_ + "/o_det", "--filter",
                      "boxes", "--quiet", "--detections", det});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(Contains(
      r.err, "warning: --detections " + det + ": 2 of its 2 stamps match no frame of the dataset"))
      << r.err;
  EXPECT_TRUE(Contains(r.err, "0 of the run's 10 frames have boxes")) << r.err;
  const RgbdDataset d = RgbdDataset::Open(dataset);
  std::ofstream(det) << d.frame(0).rgb_stamp.ToString() << " 10 10 50 50 0 0.9\n"
                     << d.frame(1).rgb_stamp.ToString() << " 10 10 50 50 999 0.9\n";
  ExpectError(Run({"run", dataset, "--config", Config(), "--out", dir_ + "/o_det2", "--filter",
                   "boxes", "--quiet", "--detections", det}),
              1, {det + ":2", "class_id 999", "0..79"});
  EXPECT_FALSE(fs::exists(dir_ + "/o_det2"));
}

// A list or ground truth cut at a line boundary reads as a shorter sequence: before, `run`
// said nothing (exit 0, "complete"). Now it names the images the list leaves out and the frames
// the ground truth does not cover.
TEST_F(DatasetCli, ListsAndGroundTruthCutAtALineBoundaryAreWarned) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const RgbdDataset d = RgbdDataset::Open(source);
  // A dataset of 10 frames laid out as TUM's: rgb/ and depth/ beside the lists (links to the
  // shared images).
  const fs::path dir = fs::path(dir_) / "cut";
  fs::create_directories(dir / "rgb");
  fs::create_directories(dir / "depth");
  std::string rgb, depth;
  for (size_t i = 0; i < 10; ++i) {
    const fs::path r = fs::path("rgb") / fs::path(d.frame(i).rgb_path).filename();
    const fs::path z = fs::path("depth") / fs::path(d.frame(i).depth_path).filename();
    fs::create_symlink(d.frame(i).rgb_path, dir / r);
    fs::create_symlink(d.frame(i).depth_path, dir / z);
    rgb += d.frame(i).rgb_stamp.ToString() + " " + r.string() + "\n";
    depth += d.frame(i).depth_stamp.ToString() + " " + z.string() + "\n";
  }
  std::ofstream(dir / "depth.txt") << depth;
  // The ground truth's poses for which `keep` holds, positions times `scale`.
  const auto write_groundtruth = [&](const std::function<bool(Timestamp)>& keep, double scale) {
    std::string gt;
    for (const StampedPose& p : ReadTumTrajectory(d.groundtruth_path())) {
      if (!keep(p.stamp)) continue;
      const Eigen::Quaterniond q = p.world_from_cam.rotation;
      const Eigen::Vector3d t = scale * p.world_from_cam.translation;
      std::ostringstream line;
      line.precision(12);
      line << p.stamp.ToString() << " " << t.x() << " " << t.y() << " " << t.z() << " " << q.x()
           << " " << q.y() << " " << q.z() << " " << q.w() << "\n";
      gt += line.str();
    }
    std::ofstream(dir / "groundtruth.txt") << gt;
  };
  // The ground truth up to frame 5 (the frames after it have none).
  write_groundtruth([&](Timestamp t) { return t <= d.frame(5).rgb_stamp; }, 1.0);
  // rgb.txt whole: the ground truth's end is warned.
  std::ofstream(dir / "rgb.txt") << rgb;
  const std::vector<std::string> args = {"run",      dir.string(), "--config",   Config(),
                                         "--direct", "--filter",   "none",       "--quiet",
                                         "--no-map", "--out",      dir_ + "/out"};
  const auto whole = Run(args);
  EXPECT_EQ(whole.code, 0) << whole.err;
  EXPECT_TRUE(Contains(whole.err, (dir / "groundtruth.txt").string() + " covers")) << whole.err;
  EXPECT_TRUE(Contains(whole.err,
                       "4 of the 10 frames have no pose of it within 0.02 s (0 before it, 4 "
                       "after it, 0 in its gaps)"))
      << whole.err;
  EXPECT_FALSE(Contains(whole.err, "images in rgb/")) << whole.err;
  // A hole: no pose from frame 3 to frame 5 (inclusive).
  write_groundtruth(
      [&](Timestamp t) {
        return SecondsBetween(t, d.frame(3).rgb_stamp) > 0.025 ||
               SecondsBetween(d.frame(5).rgb_stamp, t) > 0.025;
      },
      1.0);
  const auto hole = Run(args);
  EXPECT_TRUE(Contains(hole.err,
                       "3 of the 10 frames have no pose of it within 0.02 s (0 before "
                       "it, 0 after it, 3 in its gaps)"))
      << hole.err;
  // In millimetres: a camera does not move 190 m/s.
  write_groundtruth([](Timestamp) { return true; }, 1000.0);
  const auto millimetres = Run(args);
  EXPECT_TRUE(Contains(millimetres.err, "another unit (millimetres?) or a corrupt line?"))
      << millimetres.err;
  write_groundtruth([&](Timestamp t) { return t <= d.frame(5).rgb_stamp; }, 1.0);
  // rgb.txt cut after its 6th line: the 4 images it leaves out are warned.
  std::ofstream(dir / "rgb.txt") << rgb.substr(0, [&] {
    size_t pos = 0;
    for (int line = 0; line < 6; ++line) pos = rgb.find('\n', pos) + 1;
    return pos;
  }());
  const auto cut = Run(args);
  EXPECT_EQ(cut.code, 0) << cut.err;
  EXPECT_TRUE(Contains(
      cut.err, (dir / "rgb.txt").string() + " lists 6 of the 10 images in rgb/ (4 not listed)"))
      << cut.err;
  EXPECT_FALSE(Contains(cut.err, "have no pose of it")) << cut.err;  // the 6 frames are covered
}

}  // namespace
}  // namespace dygslam
