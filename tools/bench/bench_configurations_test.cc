// The benchmark's configurations: --filter's five and the ablation steps from the paper's method
// to ours, one extension at a time.
#include "tools/bench/bench_configurations.h"

#include <gtest/gtest.h>

#include "core/base/error.h"

namespace dygslam {
namespace {

TEST(BenchConfigurations, AblationStepsAddOneExtensionAtATimeToThePaper) {
  struct Expected {
    const char* name;
    double margin_fraction;
    bool demotion;
    bool top_up;
    bool depth_residual;
  };
  const SystemOptions defaults;
  for (const Expected& e :
       {Expected{"paper", 0.0, false, false, false},
        Expected{"paper+margin", 0.1, false, false, false},
        Expected{"paper+margin+demotion", 0.1, true, false, false},
        Expected{"full", defaults.filter.box_margin_fraction, true, true, true}}) {
    SCOPED_TRACE(e.name);
    SystemOptions o;
    ApplyFilterConfiguration(BaseFilterConfiguration(e.name), &o);
    ApplyAblationStep(e.name, &o);
    EXPECT_EQ(o.filter.mode, FilterMode::kFull);
    EXPECT_DOUBLE_EQ(o.filter.box_margin_fraction, e.margin_fraction);
    EXPECT_EQ(o.demote_in_box_features, e.demotion);
    EXPECT_EQ(o.static_top_up_fraction > 0, e.top_up);
    EXPECT_EQ(o.filter.depth_residual, e.depth_residual);
    o.filter.Check();
  }
}

TEST(BenchConfigurations, EveryFilterConfigurationIsOneAndUnknownNamesAreErrors) {
  for (const std::string& name : FilterConfigurationNames()) {
    EXPECT_EQ(BaseFilterConfiguration(name), name);
    SystemOptions a, b;
    ApplyFilterConfiguration(name, &a);
    ApplyFilterConfiguration(name, &b);
    ApplyAblationStep(name, &b);
    EXPECT_EQ(a.filter.box_margin_fraction, b.filter.box_margin_fraction) << name;
    EXPECT_EQ(a.demote_in_box_features, b.demote_in_box_features) << name;
  }
  EXPECT_EQ(BenchConfigurationNames().size(), FilterConfigurationNames().size() + 2);
  try {
    BaseFilterConfiguration("paper+demotion");
    ADD_FAILURE() << "accepted paper+demotion";
  } catch (const InvalidOptions& e) {
    EXPECT_NE(std::string(e.what()).find("paper+margin+demotion"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dygslam
