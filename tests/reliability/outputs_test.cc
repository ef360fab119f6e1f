// Outputs are transactional: every output file of a run is written under a temporary name and
// renamed over the old one only when complete; nothing in --out is deleted up front (a file an
// earlier run left stays until this run's replacement is complete, and the summary tells the two
// apart); an output that cannot be written (a --save-map onto a full disk) does not stop the others
// (exit 1 and the reason at the end).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/io/file_util.h"
#include "core/io/trajectory_io.h"
#include "run/run_outputs.h"
#include "tests/support/cli_fixture.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;
using testing::Contains;
using testing::ReadAll;

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

TEST(RunOutputsFiles, TellThisRunsFilesFromThoseAnEarlierRunLeft) {
  const fs::path dir = testing::MakeTempDir("outputs_versions");
  WriteText(dir / "trajectory.txt", "earlier run\n");
  WriteText(dir / "map.bt", "earlier map\n");
  RunOutputs outputs(dir, {"trajectory.txt", "frames.csv", "map.bt", "keyframes.txt"});
  EXPECT_TRUE(outputs.FreshNames().empty());
  ASSERT_EQ(outputs.StaleNames(), (std::vector<std::string>{"trajectory.txt", "map.bt"}));
  // Written by this run through the writer, and by another process of the run (a rename).
  EXPECT_TRUE(outputs.Write("trajectory.txt", [&] {
    WriteFileAtomically(outputs.PathOf("trajectory.txt"), "this run\n");
  }));
  WriteFileAtomically((dir / "frames.csv").string(), "stamp\n");
  EXPECT_EQ(outputs.FreshNames(), (std::vector<std::string>{"trajectory.txt", "frames.csv"}));
  EXPECT_EQ(outputs.StaleNames(), (std::vector<std::string>{"map.bt"}));
  EXPECT_EQ(ReadAll((dir / "map.bt").string()), "earlier map\n");  // kept, not deleted
  EXPECT_TRUE(outputs.failures().empty());
}

// --out removed while the run went and a link to another folder (a dataset) put in its place: the
// files that folder holds under output names were not written by this run, nor left by an
// earlier one; the summary lists neither.
TEST(RunOutputsFiles, AFolderReplacedByALinkHoldsNoFileOfThisRun) {
  const fs::path root = testing::MakeTempDir("outputs_replaced");
  const fs::path dir = root / "out", other = root / "dataset";
  fs::create_directories(dir);
  fs::create_directories(other);
  WriteText(other / "groundtruth.txt", "the dataset's ground truth\n");
  WriteText(other / "trajectory.txt", "another trajectory\n");
  RunOutputs outputs(dir, {"trajectory.txt", "groundtruth.txt"});
  fs::remove_all(dir);
  fs::create_directory_symlink(other, dir);
  EXPECT_TRUE(outputs.FreshNames().empty());
  EXPECT_TRUE(outputs.StaleNames().empty());
  // A folder made again under the name (the command does so for a removed --out): what is
  // written into it now is this run's.
  fs::remove(dir);
  fs::create_directories(dir);
  WriteFileAtomically((dir / "trajectory.txt").string(), "this run\n");
  EXPECT_EQ(outputs.FreshNames(), (std::vector<std::string>{"trajectory.txt"}));
  EXPECT_TRUE(outputs.StaleNames().empty());
}

TEST(RunOutputsFiles, AFailedWriteIsReportedAndTheOthersAreWritten) {
  const fs::path dir = testing::MakeTempDir("outputs_failure");
  WriteText(dir / "map.bt", "earlier map\n");
  RunOutputs outputs(dir, {"map.bt", "trajectory.txt"});
  outputs.AddFile((dir / "missing_folder" / "run.map").string());
  const std::string map_file = (dir / "missing_folder" / "run.map").string();
  EXPECT_FALSE(outputs.Write(map_file, [&] { WriteFileAtomically(map_file, "map"); }));
  EXPECT_FALSE(outputs.Write("map.bt", [] { throw InputError("map.bt", 0, "disk full"); }));
  EXPECT_TRUE(outputs.Write("trajectory.txt", [&] {
    WriteFileAtomically(outputs.PathOf("trajectory.txt"), "this run\n");
  }));
  ASSERT_EQ(outputs.failures().size(), 2u);
  const std::string report = outputs.FailureReport("run");
  EXPECT_TRUE(Contains(report, "dygslam run: error: " + map_file + " not written: ")) << report;
  EXPECT_TRUE(Contains(report, "does not exist")) << report;
  EXPECT_TRUE(Contains(report, "map.bt not written: map.bt: disk full")) << report;
  EXPECT_EQ(ReadAll((dir / "map.bt").string()), "earlier map\n");
  EXPECT_EQ(outputs.FreshNames(), (std::vector<std::string>{"trajectory.txt"}));
}

// A failed rename or write leaves the old file whole and no temporary file behind.
// The temporary file of an atomic write is made new under a name with a random part: a symbolic
// link planted under the name it used to have (FILE.tmp.PID) is never written through. Before,
// `eval --save-aligned` replaced the file such a link pointed to (a dataset's ground truth).
TEST(RunOutputsFiles, AnAtomicWriteNeverWritesThroughAPlantedTemporaryName) {
  const fs::path dir = testing::MakeTempDir("outputs_planted");
  const fs::path victim = dir / "groundtruth.txt";
  WriteText(victim, "the user's ground truth\n");
  const fs::path out = dir / "aligned.txt";
  const fs::path planted = out.string() + ".tmp." + std::to_string(::getpid());
  fs::create_symlink(victim, planted);
  WriteFileAtomically(out.string(), "the output\n");
  EXPECT_EQ(ReadAll(victim.string()), "the user's ground truth\n");
  EXPECT_EQ(ReadAll(out.string()), "the output\n");
  EXPECT_FALSE(fs::is_symlink(out));
  EXPECT_TRUE(fs::is_symlink(planted));  // left as it was
}

TEST(RunOutputsFiles, AnIncompleteWriteLeavesTheOldFileAndNoTemporary) {
  const fs::path dir = testing::MakeTempDir("outputs_incomplete");
  WriteText(dir / "frames.csv", "earlier\n");
  const pid_t pid = fork();
  if (pid == 0) {
    // 4 KiB file size limit: the 64 KiB write is cut short (EFBIG, SIGXFSZ ignored).
    signal(SIGXFSZ, SIG_IGN);
    const rlimit limit{4096, 4096};
    setrlimit(RLIMIT_FSIZE, &limit);
    try {
      WriteFileAtomically((dir / "frames.csv").string(), std::string(65536, 'x'));
    } catch (const InputError&) {
      std::_Exit(3);
    }
    std::_Exit(0);
  }
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 3);  // the short write is an error
  EXPECT_EQ(ReadAll((dir / "frames.csv").string()), "earlier\n");
  size_t files = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    ++files;
    EXPECT_EQ(entry.path().filename(), "frames.csv");
  }
  EXPECT_EQ(files, 1u);
}

class RunOutputsCli : public testing::CliFixture {
 protected:
  RunOutputsCli() : CliFixture("outputs_cli") {}

  // `dygslam ARGS` with the file size limit `max_file_bytes` (SIGXFSZ ignored: a write beyond it
  // fails with EFBIG, like a full disk).
  testing::ProcessResult RunWithFileSizeLimit(const std::vector<std::string>& args,
                                              rlim_t max_file_bytes) {
    const std::string out = dir_ + "/limited.out", err = dir_ + "/limited.err";
    std::vector<std::string> copy = {testing::DygslamBinary()};
    copy.insert(copy.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    const pid_t pid = fork();
    if (pid == 0) {
      if (!std::freopen(out.c_str(), "w", stdout) || !std::freopen(err.c_str(), "w", stderr))
        std::_Exit(126);
      signal(SIGXFSZ, SIG_IGN);
      const rlimit limit{max_file_bytes, max_file_bytes};
      setrlimit(RLIMIT_FSIZE, &limit);
      execv(argv[0], argv.data());
      std::_Exit(127);
    }
    std::string diagnostics;
    testing::ProcessResult r;
    r.code = testing::WaitForExit(pid, 240, &diagnostics);
    r.out = ReadAll(out);
    r.err = ReadAll(err) + diagnostics;
    return r;
  }
};

// --direct with a --save-map that cannot be written (the file size limit stands for a full disk):
// before, every frame was processed and then trajectory.txt, frames.csv and map.bt were not
// written at all (exit 1, no summary).
TEST_F(RunOutputsCli, AFailedMapSaveDoesNotStopTheOtherOutputs) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string data = SmallDataset(source, 20, "data");
  const fs::path out = fs::path(dir_) / "out";
  fs::create_directories(out);
  const std::string map_file = (out / "run.map").string();
  WriteText(map_file, "DYGSLMAP: an earlier map file\n");
  // 160 KiB: above the text outputs of 20 frames (a few KiB each) and map.bt at 5 cm (measured
  // 60-70 KiB), below the SLAM map file (measured above 1 MiB: descriptors and depth of every
  // keyframe).
  const auto r = RunWithFileSizeLimit(
      {"run", data, "--config", Config(), "--direct", "--filter", "none", "--deterministic",
       "--quiet", "--out", out.string(), "--save-map", map_file},
      160 * 1024);
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_TRUE(Contains(r.err, "dygslam run: error: " + map_file + " not written: ")) << r.err;
  EXPECT_FALSE(Contains(r.err, "internal error")) << r.err;
  // eval.json says why the run exits 1.
  const std::string json = ReadAll((out / "eval.json").string());
  EXPECT_TRUE(Contains(json, "\"error\": \"" + map_file + " not written: ")) << json;
  EXPECT_TRUE(Contains(json, "\"exit_code\": 1}")) << json;
  // The old map file is whole; every other output is this run's.
  EXPECT_EQ(ReadAll(map_file), "DYGSLMAP: an earlier map file\n");
  EXPECT_GE(ReadTumTrajectory((out / "trajectory.txt").string()).size(), 10u) << r.out;
  EXPECT_TRUE(Contains(ReadAll((out / "frames.csv").string()), "stamp,state"));
  EXPECT_TRUE(fs::exists(out / "keyframes.txt"));
  EXPECT_TRUE(fs::exists(out / "trajectory_online.txt"));
  EXPECT_TRUE(fs::exists(out / "map.bt"));
  EXPECT_TRUE(Contains(r.out, "outputs: " + out.string() +
                                  "/{trajectory.txt,trajectory_online.txt,keyframes.txt,"
                                  "frames.csv,map.bt,map.ot,eval.json}"))  // map.ot: --save-map
      << r.out;
  for (const auto& entry : fs::directory_iterator(out))
    EXPECT_FALSE(Contains(entry.path().filename().string(), ".tmp.")) << entry.path();
}

// A file an earlier run left that this run does not write (map.bt of a run with a map, then a run
// with --no-map) stays, and the summary does not list it as this run's.
TEST_F(RunOutputsCli, AnEarlierRunsFileIsKeptAndNotListedAsThisRuns) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string data = SmallDataset(source, 20, "data");
  const fs::path out = fs::path(dir_) / "out";
  fs::create_directories(out);
  WriteText(out / "map.bt", "# Octomap OcTree binary file\nearlier map\n");
  WriteText(out / "trajectory.txt", "# earlier trajectory\n");
  const auto r = Run({"run", data, "--config", Config(), "--direct", "--filter", "none",
                      "--deterministic", "--quiet", "--no-map", "--out", out.string()});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(ReadAll((out / "map.bt").string()), "# Octomap OcTree binary file\nearlier map\n");
  EXPECT_GE(ReadTumTrajectory((out / "trajectory.txt").string()).size(), 10u);
  EXPECT_TRUE(Contains(r.out, "outputs: " + out.string() +
                                  "/{trajectory.txt,trajectory_online.txt,keyframes.txt,"
                                  "frames.csv,eval.json}\n"))
      << r.out;
  EXPECT_TRUE(Contains(r.out, "outputs left from an earlier run, not replaced by this one: map.bt"))
      << r.out;
}

// The first `n` frames of `source` with their images copied into DIR/rgb and DIR/depth (the tests
// below write onto or damage images: never the shared ones); returns DIR and the colour images.
std::string CopiedDataset(const std::string& source, size_t n, const fs::path& dir,
                          std::vector<fs::path>* rgb_images) {
  fs::create_directories(dir / "rgb");
  fs::create_directories(dir / "depth");
  const RgbdDataset d = RgbdDataset::Open(source);
  std::ofstream rgb(dir / "rgb.txt"), depth(dir / "depth.txt");
  for (size_t i = 0; i < n; ++i) {
    const fs::path r = fs::path("rgb") / fs::path(d.frame(i).rgb_path).filename();
    const fs::path z = fs::path("depth") / fs::path(d.frame(i).depth_path).filename();
    fs::copy_file(d.frame(i).rgb_path, dir / r);
    fs::copy_file(d.frame(i).depth_path, dir / z);
    rgb << d.frame(i).rgb_stamp.ToString() << " " << r.string() << "\n";
    depth << d.frame(i).depth_stamp.ToString() << " " << z.string() << "\n";
    rgb_images->push_back(dir / r);
  }
  return dir.string();
}

// --save-map onto one of the dataset's images would destroy the user's data: refused before any
// work (exit 2), the image untouched. Before: the PNG became a map file, exit 0.
TEST_F(RunOutputsCli, SaveMapOntoADatasetImageIsRefused) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  std::vector<fs::path> images;
  const std::string data = CopiedDataset(source, 10, fs::path(dir_) / "data", &images);
  const fs::path image = images.front();
  const std::string before = ReadAll(image.string());
  const auto r =
      Run({"run", data, "--config", Config(), "--direct", "--filter", "none", "--quiet", "--no-map",
           "--out", (fs::path(dir_) / "out").string(), "--save-map", image.string()});
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_TRUE(Contains(r.err, "--save-map")) << r.err;
  EXPECT_TRUE(Contains(r.err, "the dataset's image listed at")) << r.err;
  EXPECT_EQ(ReadAll(image.string()), before);
  // Nor any file of the image folders (an image without a depth partner is in no frame).
  const fs::path unpaired = fs::path(data) / "rgb" / "unpaired.png";
  fs::copy_file(image, unpaired);
  const auto r2 =
      Run({"run", data, "--config", Config(), "--direct", "--filter", "none", "--quiet", "--no-map",
           "--out", (fs::path(dir_) / "out").string(), "--save-map", unpaired.string()});
  EXPECT_EQ(r2.code, 2) << r2.out << r2.err;
  EXPECT_EQ(ReadAll(unpaired.string()), before);
}

// A direct run stopped by a corrupt image mid-run writes the outputs of the frames before it and
// an eval.json that says so (exit 1 and the error): an earlier run's eval.json does not stay
// beside the new files claiming a complete run.
TEST_F(RunOutputsCli, ARunStoppedByAnErrorReplacesTheEarlierEvalJson) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  std::vector<fs::path> images;
  const std::string data = CopiedDataset(source, 20, fs::path(dir_) / "data", &images);
  const fs::path out = fs::path(dir_) / "out";
  const std::vector<std::string> args = {
      "run",  data,      "--config", Config(),          "--direct", "--filter",
      "none", "--quiet", "--no-map", "--deterministic", "--out",    out.string()};
  ASSERT_EQ(Run(args).code, 0);
  ASSERT_TRUE(Contains(ReadAll((out / "eval.json").string()), "\"complete\": true"));
  // Frame 10's colour image (a copy) made unreadable.
  ASSERT_EQ(images.size(), 20u);
  fs::remove(images[10]);
  WriteText(images[10], "not a png");
  const auto r = Run(args);
  EXPECT_EQ(r.code, 1) << r.err;
  const std::string json = ReadAll((out / "eval.json").string());
  EXPECT_TRUE(Contains(json, "\"complete\": false")) << json;
  EXPECT_TRUE(Contains(json, "\"processed\": 10,")) << json;
  EXPECT_TRUE(Contains(json, "\"exit_code\": 1}")) << json;
  EXPECT_FALSE(Contains(json, "\"error\": \"\"")) << json;
}

// `bench --update-benchmarks FILE` whose run failed (a worker stopped by a corrupt image) keeps
// the last complete figures in FILE: a partial report would drop that run's rows and misstate the
// run count. Before, the section was replaced, exit 0. It says why and exits 1; OUT/report.md
// holds the partial report.
TEST_F(RunOutputsCli, ABenchWithAFailedRunLeavesTheBenchmarksFileAsItWas) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  std::vector<fs::path> images;
  const fs::path data = fs::path(dir_) / "data";
  CopiedDataset(source, 12, data / "seq", &images);
  fs::copy_file(RgbdDataset::Open(source).groundtruth_path(), data / "seq" / "groundtruth.txt");
  fs::remove(images[6]);
  WriteText(images[6], "not a png");
  const std::string before =
      "# Benchmarks\n<!-- bench:begin -->\nthe last complete figures\n<!-- bench:end -->\n";
  const fs::path file = fs::path(dir_) / "BENCHMARKS.md";
  WriteText(file, before);
  const auto r = Run({"bench", data.string(), "--runs", "1", "--configs", "none", "--no-baseline",
                      "--no-pictures", "--quiet", "--out", (fs::path(dir_) / "b").string(),
                      "--update-benchmarks", file.string()});
  EXPECT_EQ(r.code, 1) << r.out << r.err;
  EXPECT_EQ(ReadAll(file.string()), before);
  EXPECT_TRUE(Contains(r.err, "not updated: 1 of 1 runs failed and were left out")) << r.err;
  EXPECT_TRUE(fs::exists(fs::path(dir_) / "b" / "report.md"));
}

// A bench run that fails (or is stopped) leaves the earlier bench's run folder as it was: runs.csv
// of that bench still names its files. Before, each run's folder was removed when the run
// started: a failed or stopped bench deleted the earlier trajectory, frames.csv and summary.
TEST_F(RunOutputsCli, AFailedBenchRunKeepsTheEarlierRunsFiles) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  std::vector<fs::path> images;
  const fs::path data = fs::path(dir_) / "data";
  CopiedDataset(source, 12, data / "seq", &images);
  fs::copy_file(RgbdDataset::Open(source).groundtruth_path(), data / "seq" / "groundtruth.txt");
  const std::vector<std::string> args = {"bench",
                                         data.string(),
                                         "--runs",
                                         "1",
                                         "--configs",
                                         "none",
                                         "--no-baseline",
                                         "--no-pictures",
                                         "--quiet",
                                         "--out",
                                         (fs::path(dir_) / "b").string()};
  ASSERT_EQ(Run(args).code, 0);
  const fs::path run = fs::path(dir_) / "b" / "runs" / "seq" / "none_0";
  const std::string trajectory = ReadAll((run / "trajectory.txt").string());
  ASSERT_FALSE(trajectory.empty());
  fs::remove(images[6]);
  WriteText(images[6], "not a png");
  const auto r = Run(args);
  EXPECT_EQ(r.code, 1) << r.out << r.err;
  EXPECT_EQ(ReadAll((run / "trajectory.txt").string()), trajectory);
  EXPECT_TRUE(fs::exists(run / "frames.csv"));
  EXPECT_TRUE(fs::exists(run / "summary.txt"));
  EXPECT_FALSE(fs::exists(run.string() + ".partial"));
}

}  // namespace
}  // namespace dygslam
