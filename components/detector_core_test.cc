// DetectorCore without DDS: a real Bonn frame with people -> their boxes as the frame's
// Detections message (stamp, seq, inference time), and the same boxes as the detector library's.
#include "components/detector_core.h"

#include <gtest/gtest.h>

#include "core/io/dataset.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {

DetectorOptions TestDetectorOptions(const std::string& models_dir) {
  DetectorOptions options = DetectorOptionsForModel("yolo-fastest-1.1", models_dir);
  options.num_threads = 1;
  return options;
}

RgbdFrameData FrameOfEntry(const RgbdDataset& dataset, size_t entry) {
  const auto index = dataset.FrameForRgbEntry(entry);
  EXPECT_TRUE(index);
  RgbdFrameData frame;
  frame.stamp = dataset.frame(*index).rgb_stamp;
  frame.seq = 1000 + entry;
  frame.rgb = dataset.LoadRgb(*index);
  frame.depth = dataset.LoadDepth(*index);
  frame.camera.width = frame.rgb.cols;
  frame.camera.height = frame.rgb.rows;
  return frame;
}

TEST(DetectorCore, FindsThePeopleOfARealFrame) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  DYGSLAM_REQUIRE_MODELS(models);
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  // A person fills the view at rgb.txt entries 195-208 (components/tests/carry_forward_test.cc).
  const RgbdFrameData frame = FrameOfEntry(dataset, 200);
  DetectorCore core(TestDetectorOptions(models));
  const msg::Detections out = core.Process(frame);

  EXPECT_EQ(TimeFromMsg(out.header().stamp(), "stamp"), frame.stamp);
  EXPECT_EQ(out.header().seq(), frame.seq);
  EXPECT_GT(out.inference_ms(), 0.0);
  ASSERT_FALSE(out.detections().empty()) << "no box on a frame a person fills";
  bool person = false;
  for (const Detection& d : DetectionsFromMsg(out)) {
    person = person || d.label == "person";
    EXPECT_GT(d.box.width, 0.f);
    EXPECT_GT(d.box.height, 0.f);
    EXPECT_GT(d.box.x + d.box.width, 0.f);
    EXPECT_LT(d.box.x, static_cast<float>(frame.rgb.cols));
  }
  EXPECT_TRUE(person);

  // The core adds no logic of its own: the same boxes as the detector library gives.
  std::unique_ptr<YoloDetector> detector = YoloDetector::Create(TestDetectorOptions(models));
  const std::vector<Detection> direct = detector->Detect(frame.rgb);
  const std::vector<Detection> via_core = DetectionsFromMsg(out);
  ASSERT_EQ(via_core.size(), direct.size());
  for (size_t i = 0; i < direct.size(); ++i) {
    EXPECT_EQ(via_core[i].label, direct[i].label);
    EXPECT_FLOAT_EQ(via_core[i].box.x, direct[i].box.x);
    EXPECT_FLOAT_EQ(via_core[i].box.width, direct[i].box.width);
    EXPECT_FLOAT_EQ(via_core[i].score, direct[i].score);
  }
}

}  // namespace
}  // namespace dygslam
