#include "tools/bench/bench_sequences.h"

#include <algorithm>
#include <filesystem>

#include "core/base/error.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

bool IsFile(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

bool LooksLikeSequence(const fs::path& dir) {
  return IsFile(dir / "rgb.txt") && IsFile(dir / "depth.txt");
}

void Collect(const fs::path& dir, const std::string& config_dir,
             const std::string& settings_override, int depth_left,
             std::vector<BenchSequence>* found, std::vector<std::string>* skipped) {
  if (LooksLikeSequence(dir)) {
    if (!IsFile(dir / "groundtruth.txt")) {
      if (skipped) skipped->push_back(dir.string() + ": no groundtruth.txt (cannot be scored)");
      return;
    }
    BenchSequence s;
    s.directory = dir.string();
    s.name = dir.filename().string();
    s.settings_path = settings_override.empty() ? DefaultSettingsPath(s.directory, config_dir)
                                                : settings_override;
    found->push_back(std::move(s));
    return;
  }
  if (depth_left <= 0) return;
  std::error_code ec;
  std::vector<fs::path> children;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code ec2;
    if (it->is_directory(ec2)) children.push_back(it->path());
  }
  std::sort(children.begin(), children.end());
  for (const fs::path& child : children) {
    Collect(child, config_dir, settings_override, depth_left - 1, found, skipped);
  }
}

}  // namespace

std::vector<BenchSequence> FindBenchSequences(const std::string& data_dir,
                                              const std::string& config_dir,
                                              const std::string& settings_override,
                                              std::vector<std::string>* skipped, int max_depth) {
  std::error_code ec;
  if (!fs::is_directory(data_dir, ec)) throw InputError(data_dir, 0, "not a directory");
  fs::path root = fs::absolute(data_dir, ec).lexically_normal();
  if (root.filename().empty()) root = root.parent_path();  // trailing slash
  std::vector<BenchSequence> found;
  Collect(root, config_dir, settings_override, max_depth, &found, skipped);
  return found;
}

}  // namespace dygslam
