#include "run/eval_controller.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "core/base/error.h"
#include "core/io/trajectory_io.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {

// 40 poses 0.1 s apart; the estimate is off by +-1 cm in x, alternately (ATE RMSE 1 cm: a rigid
// alignment cannot remove it).
void WritePair(const std::string& gt, const std::string& est) {
  std::ofstream g(gt), e(est);
  for (int i = 0; i < 40; ++i) {
    g << 100 + 0.1 * i << " " << 0.05 * i << " 0 0 0 0 0 1\n";
    e << 100 + 0.1 * i << " " << 0.05 * i + (i % 2 == 0 ? 0.01 : -0.01) << " 0 0 0 0 0 1\n";
  }
}

TEST(EvalController, ScoresAndSummarizesAPair) {
  const std::string dir = testing::MakeTempDir("eval_controller");
  EvalControllerOptions o;
  o.groundtruth = dir + "/gt.txt";
  o.estimate = dir + "/est.txt";
  o.save_aligned = dir + "/aligned.txt";
  WritePair(o.groundtruth, o.estimate);
  ASSERT_EQ(FindEvalFileProblem(o), "");
  const EvalSummary s = EvalController(o).Run();
  EXPECT_EQ(s.gt_poses, 40u);
  EXPECT_EQ(s.ate.num_pairs, 40u);
  EXPECT_NEAR(s.ate.error.rmse, 0.01, 1e-3);
  EXPECT_EQ(ReadTumTrajectory(o.save_aligned).size(), 40u);
  const std::string text = EvalSummaryText(s);
  EXPECT_NE(text.find("ATE  pairs 40 (100.0% of ground truth)"), std::string::npos) << text;
  EXPECT_NE(text.find("RPE  pairs"), std::string::npos) << text;
  const std::string json = EvalSummaryJson(s);
  EXPECT_NE(json.find("\"pairs\": 40,"), std::string::npos) << json;
  EXPECT_NE(json.find("\"plot\": null}"), std::string::npos) << json;
}

TEST(EvalController, FilesThatWouldBeLostAreRefusedByName) {
  const std::string dir = testing::MakeTempDir("eval_controller_files");
  EvalControllerOptions o;
  o.groundtruth = dir + "/gt.txt";
  o.estimate = dir + "/est.txt";
  WritePair(o.groundtruth, o.estimate);
  EvalControllerOptions same = o;
  same.estimate = dir + "/./gt.txt";
  EXPECT_NE(FindEvalFileProblem(same).find("the same file"), std::string::npos);
  EvalControllerOptions onto_input = o;
  onto_input.save_aligned = o.groundtruth;
  EXPECT_NE(FindEvalFileProblem(onto_input).find("GROUNDTRUTH"), std::string::npos);
  EvalControllerOptions onto_text = o;
  std::ofstream(dir + "/notes.png") << "the user's notes\n";
  onto_text.plot = dir + "/notes.png";
  onto_text.plot_script = "plot.py";
  EXPECT_NE(FindEvalFileProblem(onto_text).find("--plot"), std::string::npos);
  EvalControllerOptions unknown = o;
  unknown.calibration = "vicon";
  EXPECT_THROW(EvalController{unknown}, InvalidOptions);
}

}  // namespace
}  // namespace dygslam
