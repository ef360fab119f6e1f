// Reliability: resident memory of the DDS pipeline must level off.
//
// `dygslam run` (default mode: components as threads of one process; and --processes) on the
// 360 Bonn crowd frames. The recorder's progress line ("[run] frame N/T", every 10 frames) is
// read from the run's stderr; at each one the resident memory of the run and all its child
// processes is summed. The least-squares slope of that sum against the frame number over the
// second half of the run must stay below kMaxSlopeMbPerFrame.
//
// Before the fix (unbounded keyframe history, default malloc arenas) the default mode grew
// 0.88 MB per frame in the second half (RSS 130 -> 382 MB); after it, 0.06-0.18 MB per frame
// (the SLAM map itself grows: `--direct` ~0.05) and every --processes process <= 0.13. On a busy
// machine (one more busy core) the mapper's backlog of keyframe images added up to 0.35; it now
// queues static clouds: 0.13-0.18 with the busy core. The margin
// (0.3 MB per frame, per process) sits between the two; figures in BENCHMARKS.md.
// Filter `none` (no detector) keeps the test short: the growth came from keyframes, which every
// filter mode makes.
#include <dirent.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "core/base/child_process.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {

constexpr double kMaxSlopeMbPerFrame = 0.3;

std::string Binary() {
  if (const char* dir = std::getenv("DYGSLAM_BINARY_DIR"))
    return std::string(dir) + "/apps/dygslam";
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe");
  return (self.parent_path().parent_path().parent_path() / "apps" / "dygslam").string();
}

std::string Config() {
  return std::string(std::getenv("DYGSLAM_SOURCE_DIR")) + "/config/bonn.yaml";
}

// Parent pid of every process (from /proc/PID/stat).
std::map<pid_t, pid_t> ParentPids() {
  std::map<pid_t, pid_t> parents;
  DIR* dir = opendir("/proc");
  if (dir == nullptr) return parents;
  while (const dirent* entry = readdir(dir)) {
    const pid_t pid = static_cast<pid_t>(std::atoi(entry->d_name));
    if (pid <= 0) continue;
    const std::string text = ReadProcessFile(pid, "stat");
    const size_t paren = text.rfind(')');
    if (paren == std::string::npos) continue;
    std::istringstream rest(text.substr(paren + 2));
    char state = 0;
    pid_t ppid = 0;
    rest >> state >> ppid;
    parents[pid] = ppid;
  }
  closedir(dir);
  return parents;
}

double RssMb(pid_t pid) {
  std::istringstream status(ReadProcessFile(pid, "status"));
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::atof(line.c_str() + 6) / 1024.0;
  }
  return 0;
}

// Resident memory (MB) of `root` and of each of its descendants, by process name (the component
// name for `dygslam component NAME`, else "run").
std::map<std::string, double> TreeRssMb(pid_t root) {
  const std::map<pid_t, pid_t> parents = ParentPids();
  std::set<pid_t> tree = {root};
  for (bool grew = true; grew;) {
    grew = false;
    for (const auto& [pid, ppid] : parents) {
      if (tree.count(ppid) && !tree.count(pid)) grew = tree.insert(pid).second;
    }
  }
  std::map<std::string, double> result;
  for (pid_t pid : tree) {
    std::istringstream cmdline_file(ReadProcessFile(pid, "cmdline"));
    std::vector<std::string> argv;
    for (std::string arg; std::getline(cmdline_file, arg, '\0');) argv.push_back(arg);
    const std::string name = argv.size() > 2 && argv[1] == "component" ? argv[2] : "run";
    result[name] += RssMb(pid);
  }
  return result;
}

struct Sample {
  int frame;
  std::map<std::string, double> rss_mb;  // by process
  double total() const {
    double sum = 0;
    for (const auto& [name, mb] : rss_mb) sum += mb;
    return sum;
  }
};

struct RunTrace {
  int exit_code = -1;
  std::vector<Sample> samples;
  std::string log;
};

// Runs `args` with stderr + stdout on a pipe; one memory sample per new progress frame count.
RunTrace RunAndTrace(const std::vector<std::string>& args) {
  int fds[2];
  if (pipe(fds) != 0) return {};
  const pid_t pid = fork();
  if (pid == 0) {
    close(fds[0]);
    dup2(fds[1], STDOUT_FILENO);
    dup2(fds[1], STDERR_FILENO);
    std::vector<std::string> copy = args;
    std::vector<char*> argv;
    for (auto& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    std::_Exit(127);
  }
  close(fds[1]);
  RunTrace trace;
  const std::regex progress(R"(\[run\] frame (\d+)/)");
  int last_frame = -1;
  char buffer[4096];
  while (true) {
    pollfd p{fds[0], POLLIN, 0};
    if (poll(&p, 1, 200) <= 0) continue;
    const ssize_t n = read(fds[0], buffer, sizeof(buffer));
    if (n <= 0) break;
    const size_t scan_from = trace.log.size() > 64 ? trace.log.size() - 64 : 0;
    trace.log.append(buffer, static_cast<size_t>(n));
    const std::string tail = trace.log.substr(scan_from);
    int frame = last_frame;
    for (std::sregex_iterator it(tail.begin(), tail.end(), progress), end; it != end; ++it) {
      frame = std::max(frame, std::stoi((*it)[1]));
    }
    if (frame > last_frame) {
      trace.samples.push_back({frame, TreeRssMb(pid)});
      last_frame = frame;
    }
  }
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  trace.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return trace;
}

// Least-squares slope of `rss` against the frame number over the samples of the second half of
// the run (MB per frame).
double SecondHalfSlope(const std::vector<Sample>& samples, int frames,
                       const std::function<double(const Sample&)>& rss) {
  double n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (const Sample& s : samples) {
    if (s.frame < frames / 2) continue;
    const double y = rss(s);
    n += 1;
    sx += s.frame;
    sy += y;
    sxx += static_cast<double>(s.frame) * s.frame;
    sxy += s.frame * y;
  }
  const double denominator = n * sxx - sx * sx;
  return denominator > 0 ? (n * sxy - sx * sy) / denominator : 0;
}

// Runs `dygslam run` in `mode` on the 360 frames; every process's second-half slope must stay
// below the margin.
void ExpectBoundedMemory(const std::string& dataset, const std::string& mode, int domain) {
  const std::string out = testing::MakeTempDir("pipeline_memory_" + mode.substr(2));
  const int frames = 360;
  std::vector<std::string> args = {Binary(),
                                   "run",
                                   dataset,
                                   "--config",
                                   Config(),
                                   "--frames",
                                   "0:360",
                                   "--out",
                                   out,
                                   "--filter",
                                   "none",
                                   "--domain",
                                   std::to_string(domain)};
  if (mode != "--default") args.push_back(mode);
  const RunTrace trace = RunAndTrace(args);
  ASSERT_EQ(trace.exit_code, 0) << trace.log;
  ASSERT_GE(trace.samples.size(), 20u) << "too few progress lines\n" << trace.log;
  ASSERT_GE(trace.samples.back().frame, frames - 10) << trace.log;
  std::set<std::string> names;
  for (const Sample& s : trace.samples) {
    for (const auto& [name, mb] : s.rss_mb) names.insert(name);
  }
  std::ostringstream table;
  for (const Sample& s : trace.samples) {
    table << s.frame;
    for (const std::string& name : names) {
      table << " " << name << "=" << (s.rss_mb.count(name) ? s.rss_mb.at(name) : 0.0);
    }
    table << "\n";
  }
  std::printf(
      "%s: resident memory (all processes) %.1f MB at frame %d, %.1f MB at frame %d; "
      "second-half slope %.3f MB per frame\n",
      mode.c_str(), trace.samples.front().total(), trace.samples.front().frame,
      trace.samples.back().total(), trace.samples.back().frame,
      SecondHalfSlope(trace.samples, frames, [](const Sample& s) { return s.total(); }));
  for (const std::string& name : names) {
    const double slope = SecondHalfSlope(trace.samples, frames, [&](const Sample& s) {
      return s.rss_mb.count(name) ? s.rss_mb.at(name) : 0.0;
    });
    std::printf("  %s: second-half slope %.3f MB per frame\n", name.c_str(), slope);
    EXPECT_LT(slope, kMaxSlopeMbPerFrame)
        << mode << ", process " << name << ": resident memory (MB) per frame:\n"
        << table.str();
  }
}

TEST(PipelineMemory, DefaultModeLevelsOff) {
  DYGSLAM_REQUIRE_DATASET(dataset, "bonn_crowd_part");
  ExpectBoundedMemory(dataset, "--default", 141);
}

TEST(PipelineMemory, ProcessesModeLevelsOff) {
  DYGSLAM_REQUIRE_DATASET(dataset, "bonn_crowd_part");
  ExpectBoundedMemory(dataset, "--processes", 142);
}

}  // namespace
}  // namespace dygslam
