#include "core/io/detections_io.h"

#include <fstream>

#include <gtest/gtest.h>

#include "core/base/error.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {

std::string Write(const std::string& text) {
  const std::string path = testing::MakeTempDir("detections") + "/detections.txt";
  std::ofstream(path) << text;
  return path;
}

TEST(Detections, ReadsBoxesGroupedByStamp) {
  const auto all = ReadDetections(Write("# t x y w h class score\n1.000 10 20 30 40 0 0.9\n1.000 50 60 5 6 0 1\n1.033 1 2 3 4 0 0.5\n"));
  ASSERT_EQ(all.size(), 2u);
  const auto& first = DetectionsNear(all, *Timestamp::Parse("1.005"));
  ASSERT_EQ(first.size(), 2u);
  EXPECT_FLOAT_EQ(first[0].box.width, 30.f);
  EXPECT_EQ(first[0].label, "person");
  EXPECT_EQ(DetectionsNear(all, *Timestamp::Parse("1.030")).size(), 1u);
  EXPECT_TRUE(DetectionsNear(all, *Timestamp::Parse("2.0")).empty());  // no list within 0.02 s
}

TEST(Detections, BadLinesNameFileAndLine) {
  auto expect_error = [](const std::string& text, const std::string& fragment) {
    const std::string path = Write(text);
    try {
      ReadDetections(path);
      FAIL() << "no error for: " << text;
    } catch (const InputError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(path + ":2:"), std::string::npos) << msg;
      EXPECT_NE(msg.find(fragment), std::string::npos) << msg;
    }
  };
  expect_error("1.0 1 2 3 4 0 0.5\n1.1 1 2 3 4 0\n", "7 columns");
  expect_error("1.0 1 2 3 4 0 0.5\n1.1 1 2 nan 4 0 0.5\n", "w");
  expect_error("1.0 1 2 3 4 0 0.5\n0.9 1 2 3 4 0 0.5\n", "backwards");
  expect_error("1.0 1 2 3 4 0 0.5\n1.1 1 2 -3 4 0 0.5\n", "negative");
  expect_error("1.0 1 2 3 4 0 0.5\n1.1 1 2 3 4 0 1.5\n", "score");
}

}  // namespace
}  // namespace dygslam
