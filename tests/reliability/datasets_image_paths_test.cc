// Image paths of a dataset list that point outside the dataset folder: one warning per list file,
// naming its first such line and how many there are; refused with refuse_outside_paths.
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

class DatasetImagePaths : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = (fs::temp_directory_path() /
            ("dygslam_datasets_image_paths_" + std::to_string(::getpid()) + "_" +
             ::testing::UnitTest::GetInstance()->current_test_info()->name()))
               .string();
    fs::remove_all(dir_);
    fs::create_directories(dir_ + "/set");
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string dir_;
};

// One warning per list file, naming its first line and how many paths there are.
TEST_F(DatasetImagePaths, OutsidePathsWarnedOncePerListFile) {
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

}  // namespace
}  // namespace dygslam
