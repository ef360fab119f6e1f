// Outputs never overwrite inputs: every output path of a command is checked against every input
// path (dataset lists, settings, ground truth, loaded maps, the trajectory a map is built from) and
// against the command's other outputs; a clash is a usage error (exit 2) naming both, before any
// work, and the input is left as it was. Before, `run --save-map` onto the dataset's
// groundtruth.txt / rgb.txt / the --config file, `eval --save-aligned` / `--plot` onto the ground
// truth and `synth` into an existing dataset replaced the user's file (exit 0), and `--save-map
// OUT/trajectory.txt` said "saved" and then lost the map.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "core/io/file_util.h"
#include "core/io/trajectory_io.h"
#include "tests/support/cli_fixture.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;
using testing::Contains;
using testing::ReadAll;

TEST(OutputClash, SameFileSeesThroughSpellingsLinksAndHardLinks) {
  const fs::path dir = testing::MakeTempDir("clash_same_file");
  fs::create_directories(dir / "a");
  std::ofstream(dir / "a" / "gt.txt") << "1 0 0 0 0 0 0 1\n";
  fs::create_symlink(dir / "a", dir / "link");
  fs::create_hard_link(dir / "a" / "gt.txt", dir / "hard.txt");
  const std::string gt = (dir / "a" / "gt.txt").string();
  EXPECT_TRUE(SameFile(gt, (dir / "a" / "." / "gt.txt").string()));
  EXPECT_TRUE(SameFile(gt, (dir / "a" / ".." / "a" / "gt.txt").string()));
  EXPECT_TRUE(SameFile(gt, (dir / "link" / "gt.txt").string()));
  EXPECT_TRUE(SameFile(gt, (dir / "hard.txt").string()));
  EXPECT_TRUE(SameFile((dir / "new.txt").string(), (dir / "link" / ".." / "new.txt").string()));
  EXPECT_FALSE(SameFile(gt, (dir / "a" / "other.txt").string()));
  EXPECT_FALSE(SameFile(gt, ""));
  // Relative to the working folder.
  const fs::path cwd = fs::current_path();
  fs::current_path(dir / "a");
  EXPECT_TRUE(SameFile("gt.txt", gt));
  fs::current_path(cwd);
}

TEST(OutputClash, NamesBothFilesOfTheFirstClash) {
  const std::string none =
      FindOutputClash({{"GROUNDTRUTH", "/d/gt.txt"}},
                      {{"--save-aligned", "/d/aligned.txt"}, {"--plot", "/d/plot.png"}});
  EXPECT_EQ(none, "");
  const std::string input = FindOutputClash(
      {{"ESTIMATE", "/d/est.txt"}, {"GROUNDTRUTH", "/d/gt.txt"}}, {{"--plot", "/d/./gt.txt"}});
  EXPECT_TRUE(Contains(input, "--plot '/d/./gt.txt' is GROUNDTRUTH '/d/gt.txt', an input"))
      << input;
  const std::string output = FindOutputClash(
      {},
      {{"--save-map", "/o/trajectory.txt"}, {"the output trajectory.txt", "/o/trajectory.txt"}});
  EXPECT_TRUE(Contains(output, "is also --save-map '/o/trajectory.txt', another output")) << output;
}

// A ground truth and an estimate of 40 poses each (the estimate offset by 0.5 m).
void WriteTrajectories(const std::string& gt, const std::string& est) {
  std::ofstream g(gt), e(est);
  for (int i = 0; i < 40; ++i) {
    g << 100 + 0.1 * i << " " << 0.01 * i << " 0 0 0 0 0 1\n";
    e << 100 + 0.1 * i << " " << 0.5 + 0.01 * i << " 0 0 0 0 0 1\n";
  }
}

class OutputClashCli : public testing::CliFixture {
 protected:
  OutputClashCli() : CliFixture("clash_cli") {}

  // Starts dygslam with `args` (output in dir_/NAME.out, NAME.err; TMPDIR `tmpdir` unless "") in a
  // child that waits until `plant(pid)` has run: what is planted under the child's own pid is
  // there before it starts. Returns the child's pid (-1 after a failure).
  pid_t SpawnAfter(const std::vector<std::string>& args, const std::string& name,
                   const std::function<void(pid_t)>& plant, const std::string& tmpdir = "") {
    int gate[2];
    if (::pipe(gate) != 0) return -1;
    std::vector<std::string> argv = {testing::DygslamBinary()};
    argv.insert(argv.end(), args.begin(), args.end());
    std::vector<char*> raw;
    for (std::string& a : argv) raw.push_back(a.data());
    raw.push_back(nullptr);
    const pid_t pid = ::fork();
    if (pid == 0) {
      char c;
      ::close(gate[1]);
      if (::read(gate[0], &c, 1) != 1) std::_Exit(125);
      if (!tmpdir.empty()) ::setenv("TMPDIR", tmpdir.c_str(), 1);
      if (!std::freopen((dir_ + "/" + name + ".out").c_str(), "w", stdout) ||
          !std::freopen((dir_ + "/" + name + ".err").c_str(), "w", stderr))
        std::_Exit(126);
      ::execv(raw[0], raw.data());
      std::_Exit(127);
    }
    ::close(gate[0]);
    try {
      if (pid > 0) plant(pid);
    } catch (...) {
      ::close(gate[1]);  // the child reads the end and leaves
      throw;
    }
    const bool opened = ::write(gate[1], "x", 1) == 1;
    ::close(gate[1]);
    return opened ? pid : -1;
  }

  // Runs `args`, expects the clash (exit 2, both names) and `kept` unchanged.
  void ExpectClash(const std::vector<std::string>& args, const std::string& kept,
                   const std::vector<std::string>& needles) {
    const std::string before = ReadAll(kept);
    ASSERT_FALSE(before.empty()) << kept;
    const auto r = Run(args);
    ExpectError(r, 2, needles);
    EXPECT_TRUE(Contains(r.err, "choose another path")) << r.err;
    EXPECT_EQ(ReadAll(kept), before) << kept << " was changed";
  }
};

TEST_F(OutputClashCli, RunRefusesAnOutputOntoAnInputOrAnotherOutput) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string data = SmallDataset(source, 10, "data", /*with_groundtruth=*/true);
  const std::string out = dir_ + "/out";
  const std::string config = dir_ + "/settings.yaml";
  fs::copy_file(Config(), config);
  const std::vector<std::string> base = {"run",      data,      "--config", config,
                                         "--direct", "--quiet", "--out",    out};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = base;
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  ExpectClash(with({"--save-map", data + "/groundtruth.txt"}), data + "/groundtruth.txt",
              {"--save-map '" + data + "/groundtruth.txt' is the dataset's groundtruth.txt"});
  ExpectClash(with({"--save-map", data + "/rgb.txt"}), data + "/rgb.txt",
              {"is the dataset's rgb.txt"});
  ExpectClash(with({"--save-map", config}), config, {"--save-map '" + config + "' is --config"});
  // Another spelling of the same file.
  ExpectClash(with({"--save-map", data + "/../data/depth.txt"}), data + "/depth.txt",
              {"is the dataset's depth.txt"});
  // Onto a file the run itself writes: one of the two would be lost.
  std::ofstream(dir_ + "/marker") << "x";
  ExpectClash(with({"--save-map", out + "/trajectory.txt"}), dir_ + "/marker",
              {"the output trajectory.txt '" + out + "/trajectory.txt' is also --save-map"});
  // The loaded map is an input too.
  std::ofstream(dir_ + "/old.map") << "not read: the clash comes first";
  ExpectClash(with({"--load-map", dir_ + "/old.map", "--save-map", dir_ + "/old.map"}),
              dir_ + "/old.map", {"--save-map '" + dir_ + "/old.map' is --load-map"});
  // No work was done: nothing in --out.
  EXPECT_TRUE(!fs::exists(out) || fs::is_empty(out));
}

// Hand-started components: a recorder (or mapper) holds its kind of output in its --out through a
// lock file in the folder itself, so a second recorder is refused from any environment, private
// /tmp or mount namespace that sees the folder. Before, the lock lived at a fixed path under /tmp:
// a second recorder under a private /tmp (as systemd's PrivateTmp gives a service), or with that
// path taken by another user's plain file, was accepted and replaced the first one's trajectory.
TEST_F(OutputClashCli, AHandStartedRecorderHoldsItsFolderFromEveryNamespace) {
  const std::string out = dir_ + "/out";
  auto recorder = [&](const std::string& partition) {
    return std::vector<std::string>{"component", "recorder",    "--config", Config(),   "--out",
                                    out,         "--partition", partition,  "--domain", "161"};
  };
  const pid_t first = testing::SpawnDygslam(recorder("clash_a"), dir_ + "/a.out", dir_ + "/a.err");
  ASSERT_GT(first, 0);
  struct Stop {  // the first recorder ends with the test, whatever fails
    pid_t pid;
    ~Stop() {
      ::kill(pid, SIGTERM);
      std::string diagnostics;
      testing::WaitForExit(pid, 60, &diagnostics);
    }
  } stop{first};
  const std::string lock = out + "/.dygslam-lock.trajectories";
  // The recorder creates the file and then locks it: wait for the lock itself (seen in
  // /proc/locks, which takes no lock of its own), not only for the file.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!testing::ExclusiveFlockHeld(lock) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_TRUE(fs::exists(lock)) << ReadAll(dir_ + "/a.err");
  // The lock is the folder's own file: whoever sees the folder finds it held.
  const int fd = ::open(lock.c_str(), O_RDONLY | O_CLOEXEC);
  ASSERT_GE(fd, 0);
  EXPECT_NE(::flock(fd, LOCK_EX | LOCK_NB), 0) << "the first recorder does not hold its lock";
  ::close(fd);
  ExpectError(Run(recorder("clash_b")), 2,
              {"--out '" + out + "': another dygslam command is writing its trajectories"});
  // From a private /tmp (a mount namespace of its own; needs the privilege to make one).
  if (::geteuid() == 0) {
    std::vector<std::string> args = {"unshare",
                                     "-m",
                                     "--propagation",
                                     "private",
                                     "sh",
                                     "-c",
                                     "mount -t tmpfs none /tmp && exec \"$0\" \"$@\"",
                                     testing::DygslamBinary()};
    for (const std::string& a : recorder("clash_c")) args.push_back(a);
    const std::string err = dir_ + "/ns.err";
    std::string command;
    for (const std::string& a : args) command += "'" + a + "' ";
    const int status = std::system((command + "> /dev/null 2> '" + err + "'").c_str());
    EXPECT_EQ(WEXITSTATUS(status), 2) << ReadAll(err);
    EXPECT_TRUE(Contains(ReadAll(err), "another dygslam command is writing its trajectories"))
        << ReadAll(err);
  }
}

// The check that --out is writable makes a new file under a random name: a link planted under the
// probe's name is never written through. Before, the probe was OUT/.dygslam_write_probe.<pid>
// opened with O_TRUNC: links planted for every pid emptied any file the user could write (the
// run's own ground truth, its --config), exit 0.
TEST_F(OutputClashCli, TheWritableCheckNeverWritesThroughAPlantedLink) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string data = SmallDataset(source, 5, "data", /*with_groundtruth=*/true);
  const std::string out = dir_ + "/out", victim = dir_ + "/victim.txt";
  fs::create_directories(out);
  std::ofstream(victim) << "the user's file\n";
  const pid_t pid = SpawnAfter(
      {"run", data, "--config", Config(), "--direct", "--quiet", "--no-map", "--out", out}, "run",
      [&](pid_t child) {
        fs::create_symlink(victim, out + "/.dygslam_write_probe." + std::to_string(child));
      });
  ASSERT_GT(pid, 0);
  std::string diagnostics;
  EXPECT_EQ(testing::WaitForExit(pid, 120, &diagnostics), 0)
      << ReadAll(dir_ + "/run.err") << diagnostics;
  EXPECT_EQ(ReadAll(victim), "the user's file\n");
  EXPECT_TRUE(fs::is_symlink(out + "/.dygslam_write_probe." + std::to_string(pid)));
}

// A FIFO planted as a component's lock file is refused at once (exit 1, naming it). Before, the
// recorder waited in open() without a word until it was signalled.
TEST_F(OutputClashCli, AFifoAtALockFileIsRefusedAtOnce) {
  const std::string out = dir_ + "/out";
  fs::create_directories(out);
  ASSERT_EQ(::mkfifo((out + "/.dygslam-lock.trajectories").c_str(), 0644), 0);
  const auto r = RunWithin({"component", "recorder", "--config", Config(), "--out", out,
                            "--partition", "fifo_lock", "--domain", "162"},
                           30);
  ExpectError(r, 1, {"lock file .dygslam-lock.trajectories", "not a plain file"});
}

// `eval --plot` draws into a folder of its own: links planted in the temporary folder under the
// names it used before (dygslam_plot_<pid>.png, the script's .<name>.tmp.<pid>.png) are never
// written through. Before, the plot script's temporary file followed such a link and replaced
// the ground truth with a PNG, exit 0.
TEST_F(OutputClashCli, EvalPlotNeverWritesThroughALinkInTheTemporaryFolder) {
  const std::string gt = dir_ + "/gt.txt", est = dir_ + "/est.txt", tmp = dir_ + "/tmp";
  WriteTrajectories(gt, est);
  fs::create_directories(tmp);
  const std::string before = ReadAll(gt);
  const pid_t pid = SpawnAfter(
      {"eval", gt, est, "--plot", dir_ + "/plot.png"}, "eval",
      [&](pid_t child) {
        const std::string p = std::to_string(child);
        fs::create_symlink(gt, tmp + "/dygslam_plot_" + p + ".png");
        fs::create_symlink(gt, tmp + "/dygslam_plot_" + p + ".txt");
        for (int i = 1; i <= 50; ++i)  // the script's process: a shell and python3 after this one
          fs::create_symlink(
              gt, tmp + "/.dygslam_plot_" + p + ".png.tmp." + std::to_string(child + i) + ".png");
      },
      tmp);
  ASSERT_GT(pid, 0);
  std::string diagnostics;
  EXPECT_EQ(testing::WaitForExit(pid, 120, &diagnostics), 0)
      << ReadAll(dir_ + "/eval.err") << diagnostics;
  EXPECT_TRUE(ReadAll(gt) == before) << "the ground truth was written through a link";
  // The plot was drawn (python3-matplotlib is part of the setup), and nothing is left behind.
  EXPECT_TRUE(ReadAll(dir_ + "/plot.png").rfind("\x89PNG", 0) == 0) << ReadAll(dir_ + "/eval.err");
  size_t left = 0;
  for (const auto& e : fs::directory_iterator(tmp)) left += fs::is_symlink(e.path()) ? 0 : 1;
  EXPECT_EQ(left, 0u) << "files left in the temporary folder";
}

TEST_F(OutputClashCli, EvalRefusesToWriteOverItsInputs) {
  const std::string gt = dir_ + "/gt.txt", est = dir_ + "/est.txt";
  WriteTrajectories(gt, est);
  ExpectClash({"eval", gt, est, "--save-aligned", gt}, gt,
              {"--save-aligned '" + gt + "' is GROUNDTRUTH"});
  ExpectClash({"eval", gt, est, "--save-aligned", est}, est, {"is ESTIMATE"});
  ExpectClash({"eval", gt, est, "--plot", gt}, gt, {"--plot '" + gt + "' is GROUNDTRUTH"});
  ExpectClash({"eval", gt, est, "--plot", dir_ + "/x.png", "--save-aligned", dir_ + "/x.png"}, gt,
              {"is also --save-aligned"});
  // One file as both trajectories scores nothing.
  ExpectError(Run({"eval", gt, dir_ + "/../" + fs::path(dir_).filename().string() + "/gt.txt"}), 2,
              {"is GROUNDTRUTH '" + gt + "': the same file"});
  // --plot onto an existing file that is not a picture (a trajectory given by mistake): kept.
  const std::string notes = dir_ + "/notes.txt";
  std::ofstream(notes) << "the user's notes\n";
  const auto foreign = Run({"eval", gt, est, "--plot", notes});
  ExpectError(foreign, 2, {"--plot '" + notes + "' exists and is not a PNG picture"});
  EXPECT_EQ(ReadAll(notes), "the user's notes\n");
  // Distinct files: written.
  const auto r = Run({"eval", gt, est, "--save-aligned", dir_ + "/aligned.txt"});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir_ + "/aligned.txt"));
}

TEST_F(OutputClashCli, MapRefusesAnOutputOntoItsInputs) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string data = SmallDataset(source, 10, "data", /*with_groundtruth=*/true);
  const std::string out = dir_ + "/out";
  fs::create_directories(out);
  fs::copy_file(data + "/groundtruth.txt", out + "/trajectory.txt");
  const std::string config = out + "/map.ot";
  fs::copy_file(Config(), config);
  ExpectClash({"map", data, "--config", config, "--out", out, "--quiet"}, config,
              {"the output map.ot '" + out + "/map.ot' is --config"});
}

TEST_F(OutputClashCli, SynthRefusesAnExistingDatasetUnlessAskedToReplaceIt) {
  const std::string target = dir_ + "/dataset";
  fs::create_directories(target);
  std::ofstream(target + "/groundtruth.txt") << "1 0 0 0 0 0 0 1\n";
  const auto r = Run({"synth", target, "--frames", "2", "--quiet"});
  ExpectError(r, 2, {"OUT_DIR '" + target + "' holds a dataset (groundtruth.txt)", "--replace"});
  EXPECT_EQ(ReadAll(target + "/groundtruth.txt"), "1 0 0 0 0 0 0 1\n");
  EXPECT_FALSE(fs::exists(target + "/rgb.txt"));
  const auto replaced = Run({"synth", target, "--frames", "2", "--quiet", "--replace"});
  EXPECT_EQ(replaced.code, 0) << replaced.err;
  EXPECT_TRUE(fs::exists(target + "/rgb.txt"));
  EXPECT_NE(ReadAll(target + "/groundtruth.txt"), "1 0 0 0 0 0 0 1\n");
  // A new folder needs no flag, and keeps no staging folder.
  EXPECT_EQ(Run({"synth", dir_ + "/fresh", "--frames", "2", "--quiet"}).code, 0);
  EXPECT_FALSE(fs::exists(dir_ + "/fresh/.synth-partial"));
  // Any file of the sequence is the user's until --replace: a camera.yaml alone too.
  const std::string settings = dir_ + "/settings";
  fs::create_directories(settings);
  std::ofstream(settings + "/camera.yaml") << "%YAML:1.0\nCamera.fx: 500\n";
  ExpectError(Run({"synth", settings, "--frames", "2", "--quiet"}), 2,
              {"camera.yaml", "--replace"});
  EXPECT_EQ(ReadAll(settings + "/camera.yaml"), "%YAML:1.0\nCamera.fx: 500\n");
  // associations.txt, which a reader prefers to rgb.txt + depth.txt: refused, and with --replace
  // removed (its pairs would read the new sequence through the old dataset's pairs).
  const std::string paired = dir_ + "/paired";
  fs::create_directories(paired);
  std::ofstream(paired + "/associations.txt") << "1.0 rgb/1.png 1.0 depth/1.png\n";
  ExpectError(Run({"synth", paired, "--frames", "2", "--quiet"}), 2,
              {"holds a dataset (associations.txt)", "--replace"});
  const auto replaced_pairs = Run({"synth", paired, "--frames", "2", "--quiet", "--replace"});
  EXPECT_EQ(replaced_pairs.code, 0) << replaced_pairs.err;
  EXPECT_TRUE(Contains(replaced_pairs.err, "removed " + paired + "/associations.txt"))
      << replaced_pairs.err;
  EXPECT_FALSE(fs::exists(paired + "/associations.txt"));
}

// Starts `synth --replace` of 400 frames into `target` and sends `sig` once it has rendered a few
// frames; returns the exit status.
int StopSynthMidway(const std::string& dir, const std::string& target, int sig) {
  const pid_t pid = testing::SpawnDygslam(
      {"synth", target, "--frames", "400", "--seed", "3", "--quiet", "--replace"},
      dir + "/synth.out", dir + "/synth.err");
  const fs::path staging = target + "/.synth-partial/rgb";
  for (int i = 0; i < 600; ++i) {
    std::error_code ec;
    if (fs::is_directory(staging, ec) &&
        std::distance(fs::directory_iterator(staging, ec), fs::directory_iterator()) >= 3)
      break;
    usleep(50 * 1000);
  }
  kill(pid, sig);
  int status = 0;
  EXPECT_EQ(waitpid(pid, &status, 0), pid);
  return status;
}

// A synth --replace stopped midway leaves the folder's earlier sequence whole: the new one is
// rendered beside it and moved in only when complete. Stopped by SIGTERM / SIGINT it removes its
// unfinished render (exit 128 + signal); killed, the next synth removes it. Before: half the
// images were the new seed's while the lists still described the old one, and a SIGTERM left
// tens of MB of render behind.
TEST_F(OutputClashCli, StoppedSynthLeavesTheEarlierSequenceWhole) {
  const std::string target = dir_ + "/sequence";
  ASSERT_EQ(Run({"synth", target, "--frames", "3", "--seed", "2", "--quiet"}).code, 0);
  const std::string list = ReadAll(target + "/rgb.txt");
  std::vector<std::string> images;
  for (const auto& entry : fs::directory_iterator(target + "/rgb"))
    images.push_back(ReadAll(entry.path().string()));
  const auto expect_earlier_sequence = [&] {
    EXPECT_EQ(ReadAll(target + "/rgb.txt"), list);
    size_t k = 0;
    for (const auto& entry : fs::directory_iterator(target + "/rgb")) {
      ASSERT_LT(k, images.size());
      EXPECT_EQ(ReadAll(entry.path().string()), images[k++]) << entry.path();
    }
    EXPECT_EQ(k, images.size());
  };
  const int stopped = StopSynthMidway(dir_, target, SIGTERM);
  ASSERT_TRUE(WIFEXITED(stopped));
  EXPECT_EQ(WEXITSTATUS(stopped), 128 + SIGTERM);
  EXPECT_TRUE(Contains(ReadAll(dir_ + "/synth.err"), "stopped by signal 15 after"))
      << ReadAll(dir_ + "/synth.err");
  EXPECT_FALSE(fs::exists(target + "/.synth-partial"));
  expect_earlier_sequence();
  // Killed: its render stays until the next synth removes it (it says so) and completes.
  const int killed = StopSynthMidway(dir_, target, SIGKILL);
  EXPECT_TRUE(WIFSIGNALED(killed));
  EXPECT_TRUE(fs::exists(target + "/.synth-partial"));
  expect_earlier_sequence();
  const auto again = Run({"synth", target, "--frames", "3", "--seed", "4", "--quiet", "--replace"});
  EXPECT_EQ(again.code, 0) << again.err;
  EXPECT_TRUE(Contains(again.err, "the unfinished render of a synth that was killed")) << again.err;
  EXPECT_FALSE(fs::exists(target + "/.synth-partial"));
  EXPECT_FALSE(fs::exists(target + "/.dygslam-synth-render"));
  // A folder of the user's under that name is not synth's to remove.
  fs::create_directories(target + "/.synth-partial");
  std::ofstream(target + "/.synth-partial/thesis.tex") << "the user's text\n";
  ExpectError(Run({"synth", target, "--frames", "3", "--quiet", "--replace"}), 2,
              {"is not an unfinished synth render"});
  EXPECT_EQ(ReadAll(target + "/.synth-partial/thesis.tex"), "the user's text\n");
}

// A synth --replace killed while it moved its render in (SIGKILL between two renames) leaves the
// replaced sequence set aside in .synth-previous: the next synth puts one whole sequence back
// before anything else. Before, the old images were deleted while the old lists stayed, and the
// next synth removed the new images too: neither sequence was left.
TEST_F(OutputClashCli, ASynthKilledWhileMovingInLeavesOneWholeSequence) {
  const std::vector<std::string> kNames = {
      "rgb",      "depth",          "mask",        "rgb.txt",    "depth.txt", "groundtruth.txt",
      "mask.txt", "detections.txt", "objects.txt", "camera.yaml"};
  // `target`: the seed-2 sequence (old) and the seed-4 render (new) laid out as a killed synth
  // leaves them: the old files in .synth-previous (all of them when `all_moved`), the first
  // `moved_in` new ones in the folder, the rest in .synth-partial.
  const auto killed_state = [&](const std::string& name, bool all_moved, size_t moved_in) {
    const std::string target = dir_ + "/" + name, render = dir_ + "/" + name + "_render";
    EXPECT_EQ(Run({"synth", target, "--frames", "3", "--seed", "2", "--quiet"}).code, 0);
    EXPECT_EQ(Run({"synth", render, "--frames", "3", "--seed", "4", "--quiet"}).code, 0);
    fs::create_directories(target + "/.synth-previous");
    fs::create_directories(target + "/.synth-partial");
    std::ofstream(target + "/.synth-previous/.dygslam-synth-previous") << "set aside\n";
    std::ofstream(target + "/.synth-partial/.dygslam-synth-render") << "render\n";
    const size_t set_aside = all_moved ? kNames.size() : 4;
    for (size_t k = 0; k < set_aside; ++k)
      fs::rename(target + "/" + kNames[k], target + "/.synth-previous/" + kNames[k]);
    if (all_moved) std::ofstream(target + "/.synth-previous/.all-moved") << "all\n";
    for (size_t k = 0; k < kNames.size(); ++k)
      fs::rename(render + "/" + kNames[k],
                 target + (k < moved_in ? "/" : "/.synth-partial/") + kNames[k]);
    return target;
  };
  ASSERT_EQ(Run({"synth", dir_ + "/reference_old", "--frames", "3", "--seed", "2", "--quiet"}).code,
            0);
  ASSERT_EQ(Run({"synth", dir_ + "/reference_new", "--frames", "3", "--seed", "4", "--quiet"}).code,
            0);
  const std::string old_rgb = ReadAll(dir_ + "/reference_old/rgb.txt");
  const std::string old_truth = ReadAll(dir_ + "/reference_old/groundtruth.txt");
  const std::string new_truth = ReadAll(dir_ + "/reference_new/groundtruth.txt");
  ASSERT_NE(old_truth, new_truth);
  // Killed while the new files moved in (3 of 10 in place): the old sequence comes back whole.
  {
    const std::string target = killed_state("moving_in", true, 3);
    const auto r = Run({"synth", target, "--frames", "3", "--quiet"});  // no --replace: refused
    ExpectError(r, 2, {"holds a dataset"});
    EXPECT_TRUE(Contains(r.err, "restored the sequence in " + target)) << r.err;
    EXPECT_EQ(ReadAll(target + "/rgb.txt"), old_rgb);
    EXPECT_EQ(ReadAll(target + "/groundtruth.txt"), old_truth);
    EXPECT_EQ(RgbdDataset::Open(target).size(), 3u);
    for (size_t k = 0; k < 3; ++k) EXPECT_FALSE(RgbdDataset::Open(target).LoadRgb(k).empty());
    EXPECT_FALSE(fs::exists(target + "/.synth-previous"));
  }
  // Killed while the old files were set aside (4 of 10): the old sequence comes back whole.
  {
    const std::string target = killed_state("setting_aside", false, 0);
    const auto r = Run({"synth", target, "--frames", "3", "--quiet"});
    ExpectError(r, 2, {"holds a dataset"});
    EXPECT_EQ(ReadAll(target + "/groundtruth.txt"), old_truth);
    EXPECT_EQ(RgbdDataset::Open(target).size(), 3u);
    EXPECT_FALSE(fs::exists(target + "/.synth-previous"));
  }
  // Killed once every new file was in place: the new sequence stays.
  {
    const std::string target = killed_state("all_in", true, kNames.size());
    const auto r = Run({"synth", target, "--frames", "3", "--quiet"});
    ExpectError(r, 2, {"holds a dataset"});
    EXPECT_TRUE(Contains(r.err, "completed the replacement")) << r.err;
    EXPECT_EQ(ReadAll(target + "/groundtruth.txt"), new_truth);
    EXPECT_EQ(RgbdDataset::Open(target).size(), 3u);
    EXPECT_FALSE(fs::exists(target + "/.synth-previous"));
    EXPECT_FALSE(fs::exists(target + "/.synth-partial"));
  }
}

// --replace replaces a sequence's files and its image folders, nothing else: an image folder
// holding anything but images (the user's notes, a dataset made inside rgb/ earlier) is refused
// before any work, and nothing is removed. Before, rgb/ went as a whole with what was in it.
TEST_F(OutputClashCli, SynthReplaceKeepsWhatIsNotASequenceFile) {
  const std::string target = dir_ + "/sequence";
  ASSERT_EQ(Run({"synth", target, "--frames", "2", "--quiet"}).code, 0);
  std::ofstream(target + "/rgb/notes.txt") << "the user's notes\n";
  ExpectError(Run({"synth", target, "--frames", "2", "--quiet", "--replace"}), 2,
              {"rgb/notes.txt' is not an image of a sequence"});
  EXPECT_EQ(ReadAll(target + "/rgb/notes.txt"), "the user's notes\n");
  fs::remove(target + "/rgb/notes.txt");
  fs::create_directories(target + "/depth/nested");
  ExpectError(Run({"synth", target, "--frames", "2", "--quiet", "--replace"}), 2,
              {"depth/nested' is not an image of a sequence"});
  EXPECT_TRUE(fs::is_directory(target + "/depth/nested"));
  fs::remove(target + "/depth/nested");
  // An image of the user's that no sequence would name (not a timestamp).
  fs::copy_file(fs::directory_iterator(target + "/rgb")->path(), target + "/rgb/extra.png");
  ExpectError(Run({"synth", target, "--frames", "2", "--quiet", "--replace"}), 2,
              {"rgb/extra.png' is not an image of a sequence"});
  EXPECT_TRUE(fs::exists(target + "/rgb/extra.png"));
  fs::remove(target + "/rgb/extra.png");
  // Files beside the sequence are kept; the sequence is replaced.
  std::ofstream(target + "/README.md") << "the user's readme\n";
  const auto replaced = Run({"synth", target, "--frames", "3", "--quiet", "--replace"});
  EXPECT_EQ(replaced.code, 0) << replaced.err;
  EXPECT_EQ(ReadAll(target + "/README.md"), "the user's readme\n");
  EXPECT_EQ(std::distance(fs::directory_iterator(target + "/rgb"), fs::directory_iterator()), 3);
}

// An output folder inside a dataset's image folder (rgb/, depth/, or a folder of its images) is
// refused before any work: later reads of the dataset would find the outputs among its images.
TEST_F(OutputClashCli, OutputsNeverGoIntoADatasetsImageFolder) {
  const std::string dataset = dir_ + "/sequence";
  ASSERT_EQ(Run({"synth", dataset, "--frames", "10", "--quiet"}).code, 0);
  const size_t images =
      std::distance(fs::directory_iterator(dataset + "/rgb"), fs::directory_iterator());
  ExpectError(Run({"run", dataset, "--direct", "--filter", "none", "--no-map", "--quiet", "--out",
                   dataset + "/rgb"}),
              1, {"lies in the image folder", "of a dataset"});
  ExpectError(Run({"run", dataset, "--direct", "--filter", "none", "--no-map", "--quiet", "--out",
                   dataset + "/depth/results"}),
              1, {"lies in the image folder"});
  EXPECT_FALSE(fs::exists(dataset + "/depth/results"));
  ExpectError(Run({"synth", dataset + "/rgb/more", "--frames", "2", "--quiet"}), 2,
              {"lies in the image folder"});
  EXPECT_FALSE(fs::exists(dataset + "/rgb/more"));
  // Through a link to the image folder.
  fs::create_directory_symlink(dataset + "/rgb", dir_ + "/images");
  ExpectError(Run({"run", dataset, "--direct", "--filter", "none", "--no-map", "--quiet", "--out",
                   dir_ + "/images/results"}),
              1, {"lies in the image folder"});
  ExpectError(Run({"synth", dir_ + "/images/more", "--frames", "2", "--quiet"}), 2,
              {"lies in the image folder"});
  EXPECT_EQ(std::distance(fs::directory_iterator(dataset + "/rgb"), fs::directory_iterator()),
            static_cast<std::ptrdiff_t>(images));
  // A results folder beside the images is fine.
  const auto beside = Run({"run", dataset, "--direct", "--filter", "none", "--no-map", "--quiet",
                           "--out", dataset + "/results"});
  EXPECT_EQ(beside.code, 0) << beside.err;
}

// A dataset whose rgb.txt names an image by an absolute path outside the dataset folder: `map`'s
// pictures and `eval --plot` never go onto it (before, map_top.png replaced it, exit 0).
TEST_F(OutputClashCli, OutputsNeverGoOntoAnImageTheListsNameOutsideTheDataset) {
  const std::string dataset = dir_ + "/sequence";
  ASSERT_EQ(Run({"synth", dataset, "--frames", "6", "--quiet"}).code, 0);
  const fs::path outside = fs::path(dir_) / "elsewhere";
  fs::create_directories(outside);
  const fs::path image = outside / "map_top.png";
  // The first rgb entry moved out, listed by its absolute path.
  std::ifstream in(dataset + "/rgb.txt");
  std::string lists, line;
  bool moved = false;
  while (std::getline(in, line)) {
    if (!moved && !line.empty() && line[0] != '#') {
      const std::string stamp = line.substr(0, line.find(' '));
      const std::string relative = line.substr(line.find(' ') + 1);
      fs::rename(dataset + "/" + relative, image);
      line = stamp + " " + image.string();
      moved = true;
    }
    lists += line + "\n";
  }
  in.close();
  ASSERT_TRUE(moved);
  std::ofstream(dataset + "/rgb.txt") << lists;
  const std::string listed = "the dataset's image listed at";
  ExpectClash({"map", dataset, "--filter", "none", "--quiet", "--out", outside.string()},
              image.string(), {listed, image.string()});
  fs::copy_file(dataset + "/groundtruth.txt", dir_ + "/estimate.txt");
  ExpectClash(
      {"eval", dataset + "/groundtruth.txt", dir_ + "/estimate.txt", "--plot", image.string()},
      image.string(), {listed, image.string()});
  ExpectClash({"run", dataset, "--direct", "--filter", "none", "--quiet", "--out", dir_ + "/out",
               "--save-map", image.string()},
              image.string(), {listed, image.string()});
}

// The component command checks its files as `run` does: a slam's --save-map onto its own
// --config (or onto any file that is not a map file) is refused before any DDS work.
TEST_F(OutputClashCli, ComponentRefusesAnOutputOntoAnInputOrAForeignFile) {
  const std::string config = dir_ + "/settings.yaml";
  fs::copy_file(Config(), config);
  ExpectClash(
      {"component", "slam", "--config", config, "--out", dir_ + "/out", "--save-map", config},
      config, {"--save-map '" + config + "' is --config"});
  const std::string notes = dir_ + "/notes.txt";
  std::ofstream(notes) << "the user's notes\n";
  const auto r =
      Run({"component", "slam", "--config", config, "--out", dir_ + "/out", "--save-map", notes});
  ExpectError(r, 2, {"--save-map '" + notes + "' exists and is not a dygslam map file"});
  EXPECT_EQ(ReadAll(notes), "the user's notes\n");
}

// `run --save-map` replaces an earlier map file, never another kind of file.
TEST_F(OutputClashCli, SaveMapNeverReplacesAFileThatIsNotAMap) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string data = SmallDataset(source, 10, "data");
  const std::string notes = dir_ + "/notes.txt";
  std::ofstream(notes) << "the user's notes\n";
  const auto r = Run({"run", data, "--config", Config(), "--direct", "--quiet", "--no-map", "--out",
                      dir_ + "/out", "--save-map", notes});
  ExpectError(r, 2, {"--save-map '" + notes + "' exists and is not a dygslam map file"});
  EXPECT_EQ(ReadAll(notes), "the user's notes\n");
}

// `vocab OUT_FILE` replaces an earlier vocabulary, never another kind of file (before: any file,
// exit 0).
TEST_F(OutputClashCli, VocabNeverReplacesAFileThatIsNotAVocabulary) {
  const std::string notes = dir_ + "/notes.txt";
  std::ofstream(notes) << "the user's notes\n";
  const auto r = Run({"vocab", notes, "--scenes", "1", "--frames-per-scene", "1", "--quiet"});
  ExpectError(r, 2, {"OUT_FILE '" + notes + "' exists and is not a dygslam vocabulary file"});
  EXPECT_EQ(ReadAll(notes), "the user's notes\n");
}

// `eval --plot` / `--save-aligned` onto a file of a dataset (one of its images: a PNG, so the
// kind check alone would let it be replaced): refused, the image kept.
TEST_F(OutputClashCli, EvalNeverWritesOverAFileOfADataset) {
  const fs::path ds = fs::path(dir_) / "ds";
  fs::create_directories(ds / "rgb");
  std::ofstream(ds / "rgb.txt") << "1.0 rgb/1.png\n";
  std::ofstream(ds / "depth.txt") << "1.0 depth/1.png\n";
  const std::string image = (ds / "rgb" / "1.png").string();
  std::ofstream(image, std::ios::binary) << "\x89PNG\r\n\x1a\n the user's image";
  const std::string gt = dir_ + "/gt.txt", est = dir_ + "/est.txt";
  WriteTrajectories(gt, est);
  const std::string before = ReadAll(image);
  ExpectError(Run({"eval", gt, est, "--plot", image}), 2,
              {"--plot '" + image + "' is a file of the dataset " + ds.string()});
  ExpectError(Run({"eval", gt, est, "--save-aligned", (ds / "rgb.txt").string()}), 2,
              {"is a file of the dataset"});
  EXPECT_EQ(ReadAll(image), before);
}

// `bench --update-benchmarks FILE`: FILE is never one of the bench's own outputs (before: the
// report was written over it, then "marker not found", its text gone), and its markers are
// checked before any run.
TEST_F(OutputClashCli, BenchUpdateFileIsCheckedBeforeAnyRun) {
  const fs::path out = fs::path(dir_) / "b";
  fs::create_directories(out);
  const std::string own = (out / "report.md").string();
  std::ofstream(own) << "the user's notes\n";
  ExpectClash({"bench", dir_, "--out", out.string(), "--update-benchmarks", own}, own,
              {"is --update-benchmarks '" + own + "', an input"});
  const std::string unmarked = dir_ + "/NOTES.md";
  std::ofstream(unmarked) << "no markers here\n";
  const auto r = Run({"bench", dir_, "--out", out.string(), "--update-benchmarks", unmarked});
  ExpectError(r, 1, {unmarked, "marker <!-- bench:begin --> not found"});
  EXPECT_EQ(ReadAll(unmarked), "no markers here\n");
  EXPECT_FALSE(Contains(r.err, "no sequence found")) << r.err;  // before the data is looked at
  // A settings file named .md that carries the markers in comments is no report.
  const std::string settings = dir_ + "/other.md";
  const std::string yaml =
      "%YAML:1.0\nCamera.fx: 517.3\n# <!-- bench:begin -->\n# <!-- bench:end -->\n";
  std::ofstream(settings) << yaml;
  const auto s = Run({"bench", dir_, "--out", out.string(), "--update-benchmarks", settings});
  EXPECT_NE(s.code, 0);
  EXPECT_TRUE(Contains(s.err, "is a settings file")) << s.err;
  EXPECT_EQ(ReadAll(settings), yaml);
}

// `bench --update-benchmarks FILE` writes only into a Markdown file outside the data: a dataset's
// list or ground truth, or the bench's own --config, that holds the markers (in comment lines)
// is refused before any run. Before, it was replaced by the report, exit 0, and the dataset or
// the settings no longer read.
TEST_F(OutputClashCli, BenchNeverWritesItsReportIntoItsInputs) {
  const fs::path ds = fs::path(dir_) / "ds";
  fs::create_directories(ds / "rgb");
  const std::string marked = "# <!-- bench:begin -->\n# <!-- bench:end -->\n";
  for (const char* name : {"rgb.txt", "depth.txt", "groundtruth.txt"})
    std::ofstream(ds / name) << marked << "1.0 x\n";
  const std::string settings = dir_ + "/cfg.yaml";
  std::ofstream(settings) << marked << ReadAll(Config());
  const std::string settings_before = ReadAll(settings);
  const fs::path out = fs::path(dir_) / "b";
  for (const char* name : {"rgb.txt", "groundtruth.txt"}) {
    const std::string target = (ds / name).string();
    const std::string before = ReadAll(target);
    const auto r =
        Run({"bench", ds.string(), "--out", out.string(), "--update-benchmarks", target});
    ExpectError(r, 2, {"--update-benchmarks " + target});
    EXPECT_EQ(ReadAll(target), before) << name;
  }
  const auto r = Run({"bench", ds.string(), "--out", out.string(), "--config", settings,
                      "--update-benchmarks", settings});
  ExpectError(r, 2, {"--update-benchmarks " + settings, "not a Markdown file"});
  EXPECT_EQ(ReadAll(settings), settings_before);
  // A Markdown file inside a dataset folder is the dataset's too.
  const std::string notes = (ds / "NOTES.md").string();
  std::ofstream(notes) << marked;
  ExpectError(Run({"bench", ds.string(), "--out", out.string(), "--update-benchmarks", notes}), 2,
              {"is a file of the dataset"});
  EXPECT_EQ(ReadAll(notes), marked);
}

// `eval --save-aligned` replaces an earlier trajectory, never another kind of file (before: a
// settings file given by mistake became a trajectory, exit 0).
TEST_F(OutputClashCli, SaveAlignedNeverReplacesAFileThatIsNotATrajectory) {
  const std::string gt = dir_ + "/gt.txt", est = dir_ + "/est.txt";
  WriteTrajectories(gt, est);
  const std::string settings = dir_ + "/my.yaml";
  fs::copy_file(Config(), settings);
  const std::string before = ReadAll(settings);
  ExpectError(Run({"eval", gt, est, "--save-aligned", settings}), 2,
              {"--save-aligned '" + settings + "' exists and is not a TUM trajectory"});
  EXPECT_EQ(ReadAll(settings), before);
  // An earlier aligned trajectory is replaced.
  fs::copy_file(est, dir_ + "/aligned.txt");
  EXPECT_EQ(Run({"eval", gt, est, "--save-aligned", dir_ + "/aligned.txt"}).code, 0);
}

// A run replaces its own earlier outputs only: a file in --out with an output's name but of
// another kind (a settings file named map.bt, notes named keyframes.txt) is refused before any
// work, and kept.
TEST_F(OutputClashCli, RunNeverReplacesAFileOfAnotherKindInItsOutputFolder) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string data = SmallDataset(source, 10, "data");
  const fs::path out = fs::path(dir_) / "out";
  fs::create_directories(out);
  for (const char* name : {"map.bt", "keyframes.txt", "frames.csv"}) {
    const std::string file = (out / name).string();
    fs::copy_file(Config(), file, fs::copy_options::overwrite_existing);
    ExpectError(Run({"run", data, "--config", Config(), "--direct", "--quiet", "--filter", "none",
                     "--out", out.string()}),
                2, {"the output " + std::string(name) + " '" + file + "' exists and is not"});
    EXPECT_EQ(ReadAll(file), ReadAll(Config())) << name;
    fs::remove(file);
  }
  // A JSON file of the user's under the name eval.json (a JSON object, not a run's summary).
  const std::string notes = (out / "eval.json").string();
  std::ofstream(notes) << "{\"my\": \"notes\"}\n";
  ExpectError(Run({"run", data, "--config", Config(), "--direct", "--quiet", "--filter", "none",
                   "--out", out.string()}),
              2, {"the output eval.json '" + notes + "' exists and is not"});
  EXPECT_EQ(ReadAll(notes), "{\"my\": \"notes\"}\n");
}

}  // namespace
// `bench`, `map` and the recorder / mapper components replace their own earlier outputs only,
// like `run`: a user's files under their output names are refused before any work. Before, a
// report.md, a runs.csv or a text named like a picture were replaced, exit 0.
TEST_F(OutputClashCli, EveryCommandReplacesItsOwnOutputsOnly) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const fs::path out = fs::path(dir_) / "out";
  fs::create_directories(out);
  const auto keeps = [&](const std::string& name, const std::vector<std::string>& args,
                         const std::string& why) {
    const fs::path user = out / name;
    std::ofstream(user) << "the user's notes\n";
    ExpectError(Run(args), 2, {name, why});
    EXPECT_EQ(ReadAll(user.string()), "the user's notes\n") << name;
    fs::remove(user);
  };
  const std::vector<std::string> bench = {"bench", source, "--out", out.string(), "--runs", "1"};
  keeps("runs.csv", bench, "is not a bench's runs.csv");
  keeps("report.md", bench, "is not a bench report");
  keeps("bonn_crowd_part_features.png", bench, "is not a PNG picture");
  const std::vector<std::string> map = {"map", source, "--config", Config(), "--out", out.string()};
  keeps("map_top.png", map, "map_top.png");
  keeps("map.ot", map, "map.ot");
  keeps("keyframes.txt", map, "keyframes.txt");
  const std::vector<std::string> recorder = {"component", "recorder",   "--config", Config(),
                                             "--out",     out.string(), "--domain", "154"};
  keeps("trajectory.txt", recorder, "trajectory.txt");
  keeps("frames.csv", recorder, "frames.csv");
}

// A dataset given by associations.txt alone (rgb/, depth/, groundtruth.txt beside it) is a
// dataset too: never an output folder, its ground truth never an output. Before, `run --out` and
// `eval --save-aligned` wrote into it.
TEST_F(OutputClashCli, ADatasetOfAssociationsIsADatasetToo) {
  const fs::path ds = fs::path(dir_) / "assoc";
  fs::create_directories(ds);
  std::ofstream(ds / "associations.txt") << "1.0 rgb/1.png 1.0 depth/1.png\n";
  const std::string gt = dir_ + "/gt.txt", est = dir_ + "/est.txt";
  WriteTrajectories(gt, est);
  fs::copy_file(gt, ds / "groundtruth.txt");
  const std::string before = ReadAll((ds / "groundtruth.txt").string());
  ExpectError(Run({"eval", gt, est, "--save-aligned", (ds / "groundtruth.txt").string()}), 2,
              {"is a file of the dataset"});
  ExpectError(Run({"run", ds.string(), "--config", Config(), "--direct", "--out", ds.string()}), 1,
              {"is a dataset folder"});
  EXPECT_EQ(ReadAll((ds / "groundtruth.txt").string()), before);
}

// --save-map's folder replaced while the run goes (renamed away, a link to a dataset put in its
// place): the map goes into the folder the run started with, where it now is. Before, it was
// written through the link over the dataset's groundtruth.txt, exit 0.
TEST_F(OutputClashCli, ASaveMapFolderReplacedMidRunIsNeverWrittenThrough) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string data = SmallDataset(source, 90, "data", /*with_groundtruth=*/true);
  const std::string groundtruth = ReadAll(data + "/groundtruth.txt");
  const fs::path maps = fs::path(dir_) / "maps", moved = fs::path(dir_) / "maps.moved";
  fs::create_directories(maps);
  const std::string out = dir_ + "/out", err = dir_ + "/save.err";
  const pid_t pid = testing::SpawnDygslam(
      {"run", data, "--config", Config(), "--direct", "--filter", "none", "--quiet", "--no-map",
       "--rate", "1", "--out", out, "--save-map", (maps / "groundtruth.txt").string()},
      dir_ + "/save.out", err);
  ASSERT_GT(pid, 0);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!fs::exists(fs::path(dir_) / "save.out") && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  fs::rename(maps, moved);
  fs::create_directory_symlink(data, maps);
  std::string diagnostics;
  const int code = testing::WaitForExit(pid, 120, &diagnostics);
  EXPECT_EQ(code, 0) << ReadAll(err) << diagnostics;
  EXPECT_EQ(ReadAll(data + "/groundtruth.txt"), groundtruth) << "the dataset was written into";
  EXPECT_EQ(ReadAll((moved / "groundtruth.txt").string()).substr(0, 8), "DYGSLMAP") << ReadAll(err);
}

}  // namespace dygslam
