#include "tools/bench/bench_report.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "core/base/error.h"
#include "core/io/file_util.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {

BenchRun MakeRun(const std::string& seq, const std::string& config, int run, double rmse,
                 double total_ms) {
  BenchRun r;
  r.sequence = seq;
  r.config = config;
  r.run = run;
  r.trajectory_path = "/tmp/" + seq + "/" + config + "_" + std::to_string(run) + "/trajectory.txt";
  r.frames = 100;
  r.poses = 98;
  r.lost = 2;
  r.ate_pairs = 98;
  r.ate = ErrorStatistics{rmse, 0.8 * rmse, 0.7 * rmse, 0.5 * rmse, 0.1 * rmse, 3 * rmse};
  r.stages.orb_ms = 10 + run;
  r.stages.detection_ms = 20;
  r.stages.matching_ms = 2;
  r.stages.probability_ms = 1;
  r.stages.tracking_ms = 8;
  r.stages.total_ms = total_ms;
  r.loop_seconds = 4;
  r.fps = 25;
  r.peak_rss_mib = 300 + run;
  return r;
}

TEST(BenchReport, MedianOddEvenAndNonFinite) {
  EXPECT_DOUBLE_EQ(Median({3, 1, 2}), 2);
  EXPECT_DOUBLE_EQ(Median({4, 1, 3, 2}), 2.5);
  EXPECT_DOUBLE_EQ(Median({5, std::nan(""), 1, 3}), 3);
  EXPECT_TRUE(std::isnan(Median({})));
  EXPECT_TRUE(std::isnan(Median({std::nan("")})));
}

TEST(BenchReport, ImprovementMatchesPaperTable2) {
  // crowd1: ORB-SLAM2 0.9195, DYG-SLAM 0.0269 -> 97.07 % (paper, Table 2).
  EXPECT_NEAR(Improvement(0.0269, 0.9195), 97.07, 0.005);
  // fr3_sitting_xyz: 0.0087 -> 0.0154 is a loss: -77.01 % (Table 1).
  EXPECT_NEAR(Improvement(0.0154, 0.0087), -77.01, 0.005);
  EXPECT_TRUE(std::isnan(Improvement(0.1, 0.0)));
  EXPECT_TRUE(std::isnan(Improvement(std::nan(""), 1.0)));
}

TEST(BenchReport, SummarizeTakesMediansAndMedianRun) {
  std::vector<BenchRun> runs = {
      MakeRun("s", "full", 0, 0.030, 50), MakeRun("s", "full", 1, 0.010, 40),
      MakeRun("s", "full", 2, 0.020, 70), MakeRun("s", "full", 3, 0.050, 45),
      MakeRun("s", "full", 4, 0.015, 60)};
  const BenchCell c = Summarize(runs);
  EXPECT_EQ(c.num_runs, 5);
  EXPECT_EQ(c.num_failed, 0);
  EXPECT_DOUBLE_EQ(c.ate.rmse, 0.020);
  EXPECT_DOUBLE_EQ(c.ate.mean, 0.8 * 0.020);
  EXPECT_DOUBLE_EQ(c.stages.total_ms, 50);
  EXPECT_DOUBLE_EQ(c.stages.orb_ms, 12);
  EXPECT_DOUBLE_EQ(c.peak_rss_mib, 302);
  EXPECT_EQ(c.median_run, 2);
  EXPECT_DOUBLE_EQ(c.rmse_min, 0.010);
  EXPECT_DOUBLE_EQ(c.rmse_max, 0.050);
}

TEST(BenchReport, SummarizeLeavesFailedRunsOut) {
  std::vector<BenchRun> runs = {MakeRun("s", "none", 0, 0.3, 50), MakeRun("s", "none", 1, 0.1, 50),
                                MakeRun("s", "none", 2, std::nan(""), 50)};
  const BenchCell c = Summarize(runs);
  EXPECT_EQ(c.num_failed, 1);
  EXPECT_DOUBLE_EQ(c.ate.rmse, 0.2);
  EXPECT_TRUE(c.median_run == 0 || c.median_run == 1);
  EXPECT_DOUBLE_EQ(c.rmse_max, 0.3);
}

TEST(BenchReport, SummarizeRejectsMixedOrEmpty) {
  EXPECT_THROW(Summarize({}), std::invalid_argument);
  EXPECT_THROW(Summarize({MakeRun("a", "full", 0, 0.1, 1), MakeRun("b", "full", 0, 0.1, 1)}),
               std::invalid_argument);
  EXPECT_THROW(Summarize({MakeRun("a", "full", 0, 0.1, 1), MakeRun("a", "none", 0, 0.1, 1)}),
               std::invalid_argument);
}

TEST(BenchReport, MarkdownHasPaperLayoutAndAllConfigurations) {
  std::vector<BenchCell> cells = {Summarize({MakeRun("seqA", "none", 0, 0.9195, 43)}),
                                  Summarize({MakeRun("seqA", "full", 0, 0.0269, 52)}),
                                  Summarize({MakeRun("seqA", "boxes", 0, 0.0365, 48)}),
                                  Summarize({MakeRun("seqA", kBaselineConfig, 0, 0.5, 30)})};
  BenchContext context;
  context.command_line = "dygslam bench data";
  context.runs = 1;
  context.configs = {"none", "boxes", "full", kBaselineConfig};
  SequencePictures pics;
  pics.sequence = "seqA";
  pics.comparison_png = "seqA_compare.png";
  pics.config_pngs["full"] = "seqA_full.png";
  pics.features_png = "seqA_features.png";
  pics.features_caption = "caption";
  const std::string md = RenderBenchMarkdown(context, cells, {pics}, "docs/benchmarks/");
  // Paper layout row: no filter, full method, gamma for RMSE / mean / S.D. (all scale alike here).
  const size_t row = md.find("| seqA | 0.9195 | 0.7356 | ");
  ASSERT_NE(row, std::string::npos) << md;
  const std::string line = md.substr(row, md.find('\n', row) - row);
  EXPECT_NE(line.find("| 0.0269 | 0.0215 | "), std::string::npos) << line;
  EXPECT_NE(line.find("| 97.07 % | 97.07 % | 97.07 % |"), std::string::npos) << line;
  for (const char* config : {"none", "boxes", "full", kBaselineConfig}) {
    EXPECT_NE(md.find("| seqA | " + ConfigLabel(config) + " |"), std::string::npos) << config;
  }
  EXPECT_NE(md.find("ORB feature extraction"), std::string::npos);
  EXPECT_NE(md.find("Update geometry probability"), std::string::npos);
  EXPECT_NE(md.find("peak memory"), std::string::npos);
  EXPECT_NE(md.find("(docs/benchmarks/seqA_compare.png)"), std::string::npos);
  EXPECT_NE(md.find("(docs/benchmarks/seqA_full.png)"), std::string::npos);
  EXPECT_NE(md.find("(docs/benchmarks/seqA_features.png)"), std::string::npos);
  // Baseline timing row: only the total.
  EXPECT_NE(
      md.find("| seqA | " + ConfigLabel(kBaselineConfig) + " | - | - | - | - | - | - | 30.00 |"),
      std::string::npos)
      << md;
  // The order: configurations as given, baseline last.
  EXPECT_LT(md.find(ConfigLabel("boxes") + " | 0.0365"),
            md.find(ConfigLabel("full") + " | 0.0269"));
}

TEST(BenchReport, RunsCsvRoundTrip) {
  std::vector<BenchRun> runs = {MakeRun("s1", "none", 0, 0.123456789, 43.25),
                                MakeRun("s1", kBaselineConfig, 1, 0.5, 30)};
  const std::string dir = testing::MakeTempDir("bench_csv");
  const std::string path = dir + "/runs.csv";
  WriteFileAtomically(path, BenchRunsCsv(runs));
  const std::vector<BenchRun> back = ReadBenchRunsCsv(path);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].sequence, "s1");
  EXPECT_EQ(back[1].config, kBaselineConfig);
  EXPECT_EQ(back[1].run, 1);
  EXPECT_EQ(back[0].trajectory_path, runs[0].trajectory_path);
  EXPECT_NEAR(back[0].ate.rmse, 0.123456789, 1e-12);
  EXPECT_DOUBLE_EQ(back[0].stages.total_ms, 43.25);
  EXPECT_DOUBLE_EQ(back[1].peak_rss_mib, 301);

  WriteFileAtomically(path, "sequence,config\nx,y\n");
  try {
    ReadBenchRunsCsv(path);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path + ":1:"), std::string::npos) << e.what();
  }
  std::string text = BenchRunsCsv(runs);
  text.replace(text.find("0.123456789"), 11, "abc");
  WriteFileAtomically(path, text);
  try {
    ReadBenchRunsCsv(path);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path + ":2: column ate_rmse"), std::string::npos)
        << e.what();
  }
}

TEST(BenchReport, ReplaceBetweenMarkersKeepsTheRest) {
  const std::string text =
      "# Title\n\n## Section\n\nintro\n<!-- bench:begin -->\nold\nstuff\n<!-- bench:end -->\n\n## "
      "Other\nkeep\n";
  const std::string out = ReplaceBetweenMarkers(text, "new table\n", "B.md");
  EXPECT_EQ(out,
            "# Title\n\n## Section\n\nintro\n<!-- bench:begin -->\nnew table\n<!-- bench:end "
            "-->\n\n## Other\nkeep\n");
  // Idempotent.
  EXPECT_EQ(ReplaceBetweenMarkers(out, "new table", "B.md"), out);
}

TEST(BenchReport, ReplaceBetweenMarkersNamesTheProblem) {
  auto message = [](const std::string& text) {
    try {
      ReplaceBetweenMarkers(text, "x", "BENCHMARKS.md");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("no markers").find("BENCHMARKS.md: marker <!-- bench:begin --> not found"),
            std::string::npos);
  EXPECT_NE(message("<!-- bench:begin -->\n").find("<!-- bench:end --> not found"),
            std::string::npos);
  EXPECT_NE(message("a\n<!-- bench:end -->\n<!-- bench:begin -->\n")
                .find("BENCHMARKS.md:2: marker <!-- bench:end --> comes before"),
            std::string::npos);
  EXPECT_NE(message("<!-- bench:begin -->\n<!-- bench:end -->\n<!-- bench:begin -->\n")
                .find("BENCHMARKS.md:3: marker <!-- bench:begin --> repeated"),
            std::string::npos);
}

}  // namespace
}  // namespace dygslam

namespace dygslam {
namespace {

// Γ compares both rows on the same frames.
TEST(BenchReport, AteOnFrameSetUsesOnlyTheConfigurationsFrames) {
  std::vector<StampedPose> gt, none, full;
  for (int i = 0; i < 40; ++i) {
    const Timestamp t = Timestamp::FromNanoseconds(1'000'000'000LL + i * 33'333'000LL);
    Rigid3d pose;
    pose.translation = Eigen::Vector3d(0.05 * i, 0.01 * (i % 7), 0.0);
    gt.push_back({t, pose});
    Rigid3d drifting = pose;
    // The no-filter run is good on frames 0-19 and far off on 20-39.
    if (i >= 20) drifting.translation += Eigen::Vector3d(0, 0.3 * (i - 19) / 20.0, 0.2);
    none.push_back({t, drifting});
    if (i < 20) full.push_back({t, pose});  // the configuration has poses only for 0-19
  }
  const ErrorStatistics all = AteOnFrameSet(gt, none, none);
  const ErrorStatistics same = AteOnFrameSet(gt, none, full);
  EXPECT_GT(all.rmse, 0.05);
  EXPECT_LT(same.rmse, 1e-9);  // exactly the ground truth on those frames
  BenchCell cell = Summarize({MakeRun("seqA", "full", 0, 0.01, 50)});
  SetReferenceAte(gt, {none, none}, full, &cell);
  ASSERT_TRUE(cell.has_reference_ate);
  EXPECT_NEAR(cell.reference_ate.rmse, same.rmse, 1e-12);
  // Fewer than 3 shared frames: no reference.
  BenchCell lonely = Summarize({MakeRun("seqA", "full", 0, 0.01, 50)});
  SetReferenceAte(gt, {none}, {full.front()}, &lonely);
  EXPECT_FALSE(lonely.has_reference_ate);
}

TEST(BenchReport, GammaUsesTheReferenceOnTheSameFrames) {
  BenchCell none = Summarize({MakeRun("seqA", "none", 0, 0.9195, 43)});
  BenchCell full = Summarize({MakeRun("seqA", "full", 0, 0.0269, 52)});
  full.has_reference_ate = true;
  full.reference_ate = ErrorStatistics{0.0538, 0.8 * 0.0538, 0, 0.5 * 0.0538, 0, 0};
  BenchContext context;
  context.runs = 1;
  context.configs = {"none", "full"};
  const std::string md = RenderBenchMarkdown(context, {none, full}, {}, "");
  // η/μ = 0.5 on the same frames (not 0.0269 / 0.9195 over different frame sets).
  EXPECT_NE(md.find("| 98 / 100 | 50.00 % | 50.00 % | 50.00 % |"), std::string::npos) << md;
}

}  // namespace
}  // namespace dygslam
