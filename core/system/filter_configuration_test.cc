// Named filter configurations: the four modes and the paper's method as written.
#include <gtest/gtest.h>

#include "core/base/error.h"
#include "core/system/system.h"

namespace dygslam {
namespace {

TEST(FilterConfiguration, PaperRunsWithoutOurExtensions) {
  struct Expected {
    const char* name;
    double margin_fraction;
    bool demotion;
    bool top_up;
    bool depth_residual;  // ours; the paper family runs the paper's epipolar test
  };
  const SystemOptions defaults;
  for (const Expected& e :
       {Expected{"paper", 0.0, false, false, false},
        Expected{"full", defaults.filter.box_margin_fraction, true, true, true}}) {
    SCOPED_TRACE(e.name);
    SystemOptions o;
    o.filter.mode = FilterMode::kNone;
    ApplyFilterConfiguration(e.name, &o);
    EXPECT_EQ(o.filter.mode, FilterMode::kFull);
    EXPECT_TRUE(o.NeedsDetections());
    EXPECT_DOUBLE_EQ(o.filter.box_margin_fraction, e.margin_fraction);
    EXPECT_EQ(o.demote_in_box_features, e.demotion);
    EXPECT_EQ(o.static_top_up_fraction > 0, e.top_up);
    EXPECT_EQ(o.filter.depth_residual, e.depth_residual);
    o.filter.Check();
  }
  // The paper's parameters are untouched by the presets (C1, alpha, Q, R, P_init, C2, delta).
  SystemOptions paper;
  ApplyFilterConfiguration("paper", &paper);
  EXPECT_EQ(paper.filter.c1, 2.0);
  EXPECT_EQ(paper.filter.alpha, 0.4);
  EXPECT_EQ(paper.filter.q, 0.09);
  EXPECT_EQ(paper.filter.r, 1.0);
  EXPECT_EQ(paper.filter.p_init, 0.6);
  EXPECT_EQ(paper.filter.c2, 1.0);
  EXPECT_EQ(paper.filter.delta, 60.0);
  EXPECT_EQ(paper.filter.threshold, 0.5);
  EXPECT_EQ(paper.filter.box_margin, 0.0);
}

TEST(FilterConfiguration, ModesKeepTheSettingsFileValues) {
  SystemOptions o;
  o.filter.box_margin_fraction = 0.25;  // as if from the settings file
  o.static_top_up_fraction = 0.5;
  for (const char* name : {"none", "boxes", "geometry", "full"}) {
    ApplyFilterConfiguration(name, &o);
    EXPECT_EQ(ToString(o.filter.mode), std::string(name));
    EXPECT_EQ(o.filter.box_margin_fraction, 0.25);
    EXPECT_EQ(o.static_top_up_fraction, 0.5);
  }
}

TEST(FilterConfiguration, UnknownNameIsAnErrorListingTheNames) {
  SystemOptions o;
  // The ablation steps are the benchmark's configurations (tools/bench), not --filter's.
  for (const char* bad : {"", "Paper", "paper+demotion", "papers", "full+", "paper+margin"}) {
    try {
      ApplyFilterConfiguration(bad, &o);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const InvalidOptions& e) {
      EXPECT_NE(std::string(e.what()).find("none|boxes|geometry|paper|full"), std::string::npos)
          << e.what();
    }
  }
  EXPECT_EQ(FilterConfigurationNames().size(), 5u);
}

}  // namespace
}  // namespace dygslam
