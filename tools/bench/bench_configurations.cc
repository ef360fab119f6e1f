#include "tools/bench/bench_configurations.h"

#include <algorithm>

#include "core/base/error.h"

namespace dygslam {
namespace {

constexpr const char* kPaperMargin = "paper+margin";
constexpr const char* kPaperMarginDemotion = "paper+margin+demotion";

}  // namespace

const std::vector<std::string>& BenchConfigurationNames() {
  static const std::vector<std::string> names = {
      "none", "boxes", "geometry", "paper", kPaperMargin, kPaperMarginDemotion, "full"};
  return names;
}

std::string BaseFilterConfiguration(const std::string& name) {
  const auto& names = BenchConfigurationNames();
  if (std::find(names.begin(), names.end(), name) == names.end()) {
    std::string list;
    for (const std::string& n : names) list += (list.empty() ? "" : "|") + n;
    throw InvalidOptions("invalid filter configuration '" + name + "': expected " + list);
  }
  return name == kPaperMargin || name == kPaperMarginDemotion ? "paper" : name;
}

void ApplyAblationStep(const std::string& name, SystemOptions* options) {
  if (name == kPaperMargin || name == kPaperMarginDemotion)
    options->filter.box_margin_fraction = 0.1;
  if (name == kPaperMarginDemotion) options->demote_in_box_features = true;
}

}  // namespace dygslam
