// Output folders pinned at the start of a command: WriteFileAtomically follows the folder the
// command started with when it was moved, and refuses to write into whatever took its place,
// naming what is there.
#include "core/io/file_util.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "core/base/error.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

std::string ErrorOfWritingInto(const std::string& dir) {
  try {
    WriteFileAtomically(dir + "/out.txt", "x");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(PinnedFolder, AMovedFolderIsFollowed) {
  const std::string root = testing::MakeTempDir("pinned_moved");
  const std::string dir = root + "/out";
  fs::create_directories(dir);
  PinOutputFolder(dir);
  fs::rename(dir, root + "/moved");
  WriteFileAtomically(dir + "/out.txt", "x");
  EXPECT_TRUE(fs::exists(root + "/moved/out.txt"));
  EXPECT_FALSE(fs::exists(dir + "/out.txt"));
}

TEST(PinnedFolder, WhatTookTheRemovedFolderPlaceIsNamed) {
  const std::string root = testing::MakeTempDir("pinned_replaced");
  const std::string file_dir = root + "/by_file", full_dir = root + "/by_folder";
  for (const std::string& dir : {file_dir, full_dir}) {
    fs::create_directories(dir);
    PinOutputFolder(dir);
    fs::remove_all(dir);
  }
  std::ofstream(file_dir) << "";  // an empty file where the folder was
  fs::create_directories(full_dir);
  std::ofstream(full_dir + "/theirs.txt") << "keep";
  const std::string by_file = ErrorOfWritingInto(file_dir);
  EXPECT_NE(by_file.find("(a file)"), std::string::npos) << by_file;
  const std::string by_folder = ErrorOfWritingInto(full_dir);
  EXPECT_NE(by_folder.find("(a folder with files)"), std::string::npos) << by_folder;
  EXPECT_FALSE(fs::exists(full_dir + "/out.txt"));
}

}  // namespace
}  // namespace dygslam
