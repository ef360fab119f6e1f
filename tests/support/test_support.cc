#include "tests/support/test_support.h"

#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <thread>

#include "core/base/paths.h"

namespace dygslam::testing {
namespace fs = std::filesystem;

namespace {
// Test processes get the build-time locations unless the environment overrides them.
const bool kEnvironmentReady = [] {
  ::setenv("DYGSLAM_SOURCE_DIR", DYGSLAM_BAKED_SOURCE_DIR, 0);
  ::setenv("DYGSLAM_BINARY_DIR", DYGSLAM_BAKED_BINARY_DIR, 0);
  ::setenv("DYGSLAM_DEFAULT_DATA_DIR", DYGSLAM_BAKED_DATA_DIR, 0);
  ::setenv("DYGSLAM_DEFAULT_MODELS_DIR", DYGSLAM_BAKED_MODELS_DIR, 0);
  return true;
}();
}  // namespace

std::string DataDir() { return ::dygslam::DataDir(); }

std::string DatasetDir(const std::string& name) {
  const std::string root = DataDir();
  if (root.empty()) return "";
  const fs::path p = fs::path(root) / name;
  std::error_code ec;
  return fs::is_directory(p, ec) ? p.string() : "";
}

std::string ModelsDir() { return ::dygslam::ModelsDir(); }

bool RequireData() {
  auto set = [](const char* name) {
    const char* v = std::getenv(name);
    if (v == nullptr) return false;
    const std::string s(v);
    return !s.empty() && s != "0" && s != "false";
  };
  return set("DYGSLAM_REQUIRE_DATA") || set("CI");
}

std::string MakeTempDir(const std::string& prefix) {
  static std::atomic<int> counter{0};
  const char* bin = std::getenv("DYGSLAM_BINARY_DIR");
  fs::path root = bin ? fs::path(bin) / "test_tmp" : fs::temp_directory_path() / "dygslam_test_tmp";
  fs::path dir =
      root / (prefix + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string DygslamBinary() {
  const char* bin = std::getenv("DYGSLAM_BINARY_DIR");
  return (fs::path(bin ? bin : DYGSLAM_BAKED_BINARY_DIR) / "apps" / "dygslam").string();
}

pid_t SpawnDygslam(const std::vector<std::string>& args, const std::string& out,
                   const std::string& err) {
  std::vector<std::string> copy = {DygslamBinary()};
  copy.insert(copy.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : copy) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {
    // Its own process group, as a shell with job control starts a command: a test that stops one
    // of its processes (SIGSTOP) then never leaves a stopped job in the suite's group, which the
    // kernel answers with SIGHUP and SIGCONT to the whole group when an exit orphans it.
    setpgid(0, 0);
    if (!std::freopen(out.c_str(), "w", stdout) || !std::freopen(err.c_str(), "w", stderr))
      std::_Exit(126);
    execv(argv[0], argv.data());
    std::_Exit(127);
  }
  return pid;
}

ProcessResult RunDygslam(const std::vector<std::string>& args, const std::string& scratch_dir) {
  static std::atomic<int> counter{0};
  const int n = counter++;
  const std::string out =
      (fs::path(scratch_dir) / ("stdout_" + std::to_string(n) + ".txt")).string();
  const std::string err =
      (fs::path(scratch_dir) / ("stderr_" + std::to_string(n) + ".txt")).string();
  const pid_t pid = SpawnDygslam(args, out, err);
  int status = 0;
  waitpid(pid, &status, 0);
  ProcessResult r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  r.out = ReadAll(out);
  r.err = ReadAll(err);
  return r;
}

int WaitForExit(pid_t pid, double timeout_s, std::string* diagnostics) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  int status = 0;
  while (std::chrono::steady_clock::now() < deadline) {
    const pid_t r = waitpid(pid, &status, WNOHANG);
    if (r == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    if (r < 0) return -1;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::string text = "process " + std::to_string(pid) + " still running after " +
                     std::to_string(timeout_s) + " s (hang); its threads:\n";
  // The process's threads, then those of its children (a `run --processes` hangs in the
  // component that waits, not in the supervisor).
  const std::string p = std::to_string(pid);
  const std::string cmd =
      "stacks() { gdb -p $1 -batch -nx -ex 'thread apply all bt 25' 2>&1 | "
      "grep -E '^(#|Thread)'; }; stacks " +
      p + "; for c in $(pgrep -P " + p +
      "); do echo; echo \"child $c: $(tr '\\0' ' ' < /proc/$c/cmdline | cut -c1-200)\"; "
      "stacks $c; done";
  if (FILE* pipe = ::popen(cmd.c_str(), "r")) {
    char buffer[4096];
    while (std::fgets(buffer, sizeof buffer, pipe)) text += buffer;
    ::pclose(pipe);
  }
  ::kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  if (diagnostics) *diagnostics += text;
  return -1;
}

bool ExclusiveFlockHeld(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return false;
  // Lines such as "1: FLOCK  ADVISORY  WRITE 1234 08:01:5678 0 EOF" (the file as device:inode);
  // a waiter's line has "->" and is not a hold.
  std::ifstream locks("/proc/locks");
  const std::string inode = ":" + std::to_string(static_cast<unsigned long long>(st.st_ino)) + " ";
  for (std::string line; std::getline(locks, line);) {
    if (line.find("->") != std::string::npos) continue;
    if (line.find("FLOCK") != std::string::npos && line.find("WRITE") != std::string::npos &&
        line.find(inode) != std::string::npos)
      return true;
  }
  return false;
}

}  // namespace dygslam::testing
