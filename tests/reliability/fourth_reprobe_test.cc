// Fourth re-probe of issue 20 (2026-12-02, tests/reliability/probe/hostile_probe.sh extended to
// ~230 probes), the library half: each case failed before its fix.
//   P1  an image list with many paths outside the dataset folder printed one warning per line
//       (360 lines of warnings for a list of absolute paths): now one per list file, with a count
//   P2  a settings file with a second YAML document ("---" or "..." then more keys): the second
//       document's keys were dropped without a word (YAML::Load reads the first one only)
//   P3  a YAML merge key ("<<: *base"): the merged values were dropped, with an unknown-key
//       warning that suggested the key it had dropped ("did you mean 'DynamicFilter.alpha'?")
//   P4  a value that underflows a double (4.9e-324) was called "not a finite number"
//   P11 `Camera.fps: 1e20` was reported as "key 'Tracking.max_frames_between_keyframes': invalid
//       value" without a line (the derived keyframe interval overflowed); `ThDepth: 1e20` was
//       accepted without a word (every point "close"), so was `DepthMapFactor: 1e20`
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/config/config_reader.h"
#include "core/config/settings.h"
#include "core/io/dataset.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

size_t Count(const std::string& text, const std::string& needle) {
  size_t n = 0;
  for (size_t at = text.find(needle); at != std::string::npos; at = text.find(needle, at + 1)) ++n;
  return n;
}

class FourthReprobe : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = (fs::temp_directory_path() /
            ("dygslam_fourth_reprobe_" + std::to_string(::getpid()) + "_" +
             ::testing::UnitTest::GetInstance()->current_test_info()->name()))
               .string();
    fs::remove_all(dir_);
    fs::create_directories(dir_ + "/set");
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string dir_;
};

// P1: one warning per list file, naming its first line and how many paths there are.
TEST_F(FourthReprobe, OutsidePathsWarnedOncePerListFile) {
  for (int i = 0; i < 4; ++i) std::ofstream(dir_ + "/img" + std::to_string(i) + ".png") << "x";
  std::ofstream rgb(dir_ + "/set/rgb.txt"), depth(dir_ + "/set/depth.txt");
  rgb << "# rgb\n";
  depth << "# depth\n";
  for (int i = 0; i < 4; ++i) {
    // Lines 2..5 of rgb.txt: three outside (relative and absolute), one inside.
    const std::string stamp = std::to_string(1 + i) + ".0";
    if (i == 1) {
      std::ofstream(dir_ + "/set/in.png") << "x";
      rgb << stamp << " in.png\n";
    } else if (i == 2) {
      rgb << stamp << " " << dir_ << "/img2.png\n";
    } else {
      rgb << stamp << " ../img" << i << ".png\n";
    }
    depth << stamp << " ../img" << i << ".png\n";
  }
  rgb.close();
  depth.close();
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(RgbdDataset::Open(dir_ + "/set").size(), 4u);
  const std::string warnings = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(Count(warnings, "warning: "), 2u) << "one per list file:\n" << warnings;
  EXPECT_TRUE(warnings.find("warning: " + dir_ +
                            "/set/rgb.txt:2: image path ../img0.png is outside the dataset "
                            "folder") != std::string::npos)
      << warnings;
  EXPECT_TRUE(warnings.find("(and 2 more image paths of this file outside it: 3 in all)") !=
              std::string::npos)
      << warnings;
  EXPECT_TRUE(warnings.find("depth.txt:2:") != std::string::npos) << warnings;
  EXPECT_TRUE(warnings.find("4 in all") != std::string::npos) << warnings;

  // associations.txt: both columns of every line count, one warning.
  std::ofstream(dir_ + "/set/associations.txt") << "1.0 ../img0.png 1.0 ../img1.png\n"
                                                << "2.0 in.png 2.0 ../img1.png\n";
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(RgbdDataset::Open(dir_ + "/set").size(), 2u);
  const std::string assoc = ::testing::internal::GetCapturedStderr();
  // One warning for associations.txt (rgb.txt, read too, has its own).
  EXPECT_EQ(Count(assoc, "associations.txt:"), 1u) << assoc;
  EXPECT_TRUE(assoc.find("associations.txt:1:") != std::string::npos) << assoc;
  EXPECT_TRUE(assoc.find("3 in all") != std::string::npos) << assoc;

  // --strict-paths still refuses at the first such line.
  DatasetOptions refuse;
  refuse.refuse_outside_paths = true;
  fs::remove(dir_ + "/set/associations.txt");
  try {
    RgbdDataset::Open(dir_ + "/set", refuse);
    ADD_FAILURE() << "outside paths accepted with refuse_outside_paths";
  } catch (const InputError& e) {
    EXPECT_TRUE(std::string(e.what()).find("rgb.txt:2:") != std::string::npos) << e.what();
  }
}

// The InputError message of reading `text` ("" and a failure when it is accepted).
std::string ReadError(const std::string& text) {
  try {
    const ConfigReader reader = ConfigReader::FromString(text, "bad.yaml");
    reader.Get<double>("Camera.fx", 0);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "accepted:\n" << text;
  return "";
}

// P2: the keys of a second document are not dropped without a word.
TEST(FourthReprobeSettings, SecondDocumentIsAnError) {
  for (const std::string& text : {std::string("Camera.fx: 500\n---\nCamera.fy: 500\n"),
                                  std::string("Camera.fx: 500\n...\nCamera.fy: 12\n")}) {
    const std::string e = ReadError(text);
    EXPECT_NE(e.find("bad.yaml:3:"), std::string::npos) << e;
    EXPECT_NE(e.find("second YAML document"), std::string::npos) << e;
  }
  // A document marker at the start, or a trailing one with nothing after it, is fine.
  for (const std::string& text :
       {std::string("---\nCamera.fx: 500\n"), std::string("Camera.fx: 500\n---\n"),
        std::string("Camera.fx: 500\n...\n"), std::string("%YAML:1.0\n---\nCamera.fx: 7\n")}) {
    EXPECT_NO_THROW({
      const ConfigReader reader = ConfigReader::FromString(text, "ok.yaml");
      EXPECT_GT(reader.Get<double>("Camera.fx", 0), 0) << text;
    }) << text;
  }
}

// Found by the settings fuzzer (CI): a ',' at the top level made yaml-cpp's LoadAll hand out empty
// documents at the same place forever (the run hung). Now an error naming the file and line.
TEST(FourthReprobeSettings, StrayCommaIsAnErrorNotAHang) {
  for (const std::string& text :
       {std::string(","), std::string(", Camera.fx: 500\n"),
        std::string("Camera.fx: 500\n---\n,\n"), std::string("%YAML:1.0\n---\n, x\n")}) {
    const std::string e = ReadError(text);
    EXPECT_NE(e.find("bad.yaml:"), std::string::npos) << e;
    EXPECT_TRUE(e.find("','") != std::string::npos || e.find("malformed YAML") != std::string::npos)
        << e;
  }
  // Commas inside flow collections and inside values are of course fine.
  const ConfigReader reader =
      ConfigReader::FromString("Camera.fx: 500\nlist: [1, 2, 3]\nname: a, b\n", "ok.yaml");
  EXPECT_EQ(reader.Get<std::vector<int>>("list", {}), (std::vector<int>{1, 2, 3}));
  EXPECT_EQ(reader.Get<std::string>("name", ""), "a, b");
}

// P3: a merge key is an error with its line, not a value dropped below a key named "<<".
TEST(FourthReprobeSettings, MergeKeyIsAnError) {
  for (const std::string& text :
       {std::string("base: &b {alpha: 0.9}\nDynamicFilter:\n  <<: *b\n"),
        std::string("x: 1\ny: 2\nDynamicFilter: {<<: {threshold: 0.7}}\n")}) {
    const std::string e = ReadError(text);
    EXPECT_NE(e.find("bad.yaml:3:"), std::string::npos) << e;
    EXPECT_NE(e.find("merge key '<<' is not supported"), std::string::npos) << e;
  }
  // A quoted "<<" is a plain (unknown) key name, no merge.
  EXPECT_NO_THROW(ConfigReader::FromString("\"<<\": 1\n", "ok.yaml"));
}

// P4: an underflowing value is named as such.
TEST(FourthReprobeSettings, UnderflowIsNamed) {
  const std::string e = ReadError("Camera.fx: 4.9e-324\n");
  EXPECT_NE(e.find("underflow"), std::string::npos) << e;
  EXPECT_EQ(e.find("finite"), std::string::npos) << e;
  EXPECT_NE(ReadError("Camera.fx: 1e400\n").find("finite"), std::string::npos);
}

// P11: absurd frame rate and close-depth factor are errors naming their own key and line.
TEST(FourthReprobeSettings, AbsurdFpsAndThDepthNameTheirKey) {
  std::ifstream in(std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml");
  const std::string bonn((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const auto& [key, line_text] :
       {std::pair<std::string, std::string>{"Camera.fps", "Camera.fps: 1e20"},
        {"ThDepth", "ThDepth: 1e20"},
        {"DepthMapFactor", "DepthMapFactor: 1e20"}}) {
    std::string text = bonn;
    const size_t at = text.find("\n" + key + ":");
    ASSERT_NE(at, std::string::npos) << key;
    text.replace(at + 1, text.find('\n', at + 1) - at - 1, line_text);
    const int line = static_cast<int>(std::count(text.begin(), text.begin() + at + 1, '\n')) + 1;
    try {
      ParseSettings(text, "bad.yaml");
      ADD_FAILURE() << line_text << " accepted";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("bad.yaml:" + std::to_string(line) + ": key '" + key + "'"),
                std::string::npos)
          << what;
      EXPECT_NE(what.find("implausible"), std::string::npos) << what;
    }
  }
  // The shipped values pass.
  EXPECT_NO_THROW(ParseSettings(bonn, "bonn.yaml"));
}

}  // namespace
}  // namespace dygslam
