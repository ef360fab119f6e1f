// OctoMap files given to --load-octomap: a truncated tree or nodes nested deeper than an OcTree's
// levels are errors naming the file (OctoMap's own reader would take what it read), and header
// messages are echoed whole, escaped.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/base/input_file.h"
#include "core/base/stop_signal.h"
#include "core/config/config_reader.h"
#include "core/config/settings.h"
#include "core/io/dataset.h"
#include "core/io/detections_io.h"
#include "mapping/octomap_builder.h"
#include "mapping/octomap_settings.h"
#include "run/settings_table.h"
#include "run/system_config.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

std::string BonnYaml() {
  std::ifstream in(std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml");
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

bool Contains(const std::string& text, const std::string& needle) {
  return text.find(needle) != std::string::npos;
}

// The InputError of reading `text` the way `dygslam run` does ("" and a failure if accepted).
std::string SettingsError(const std::string& text, std::vector<std::string>* warnings = nullptr) {
  try {
    const Settings settings = ParseSettings(text, "bad.yaml");
    if (warnings != nullptr) *warnings = settings.warnings;
    SystemOptionsFromSettings(settings);
    OctoMapOptions octomap;
    ReadOptions(settings.reader, &octomap);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "accepted:\n" << text.substr(text.size() > 200 ? text.size() - 200 : 0);
  return "";
}

// bonn.yaml with `line` replaced (flat ORB-SLAM2 keys) or a section appended.
std::string WithFlat(const std::string& key, const std::string& value) {
  std::string text = BonnYaml();
  const size_t at = text.find("\n" + key + ":");
  EXPECT_NE(at, std::string::npos) << key;
  const size_t end = text.find('\n', at + 1);
  text.replace(at + 1, end - at - 1, key + ": " + value);
  return text;
}

// A small map written as .ot / .bt.
octomap::OcTree SmallTree() {
  octomap::OcTree tree(0.05);
  for (int i = 0; i < 400; ++i)
    tree.updateNode(octomap::point3d(0.05f * (i % 20), 0.05f * (i / 20), 0.3f), i % 3 != 0);
  return tree;
}

// A truncated .ot (or .bt) is an error naming the file; a complete one reads;
// a header with a NUL byte is echoed escaped.
TEST(OctoMapFiles, TruncatedOctoMapIsAnError) {
  const fs::path dir = testing::MakeTempDir("map_files_octomap_ot");
  octomap::OcTree tree = SmallTree();
  const std::string ot = (dir / "map.ot").string(), bt = (dir / "map.bt").string();
  ASSERT_TRUE(tree.write(ot));
  ASSERT_TRUE(tree.writeBinary(bt));
  EXPECT_EQ(ReadOctoMap(ot)->size(), tree.size());
  EXPECT_GT(ReadOctoMap(bt)->size(), 0u);
  for (const std::string& full : {ot, bt}) {
    const std::string bytes = testing::ReadAll(full);
    for (const double share : {0.5, 0.9}) {
      const std::string cut = full + ".cut";
      std::ofstream(cut, std::ios::binary)
          << bytes.substr(0, static_cast<size_t>(bytes.size() * share));
      try {
        ReadOctoMap(cut);
        ADD_FAILURE() << "truncated " << full << " at " << share << " accepted";
      } catch (const InputError& e) {
        EXPECT_TRUE(Contains(e.what(), cut)) << e.what();
        EXPECT_TRUE(Contains(e.what(), "truncated or corrupt")) << e.what();
      }
    }
  }
  const std::string nul = (dir / "nul.ot").string();
  std::ofstream(nul, std::ios::binary) << std::string("# Octo\0map junk after\n", 22);
  try {
    ReadOctoMap(nul);
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_TRUE(Contains(e.what(), "# Octo\\x00map junk")) << e.what();
  }
}

// A crafted OctoMap whose nodes nest a million levels deep (each node's only child is the next
// node; OctoMap's trees have 16 levels): OctoMap's readers recurse once per level and overflowed
// the stack (SIGSEGV). Now an error naming the file and the depth, for .ot and .bt; a valid map
// of the full 16 levels still reads.
TEST(OctoMapFiles, DeeplyNestedOctoMapIsAnError) {
  const fs::path dir = testing::MakeTempDir("map_files_octomap_deep");
  constexpr long long kNodes = 1000000;
  const std::string ot = (dir / "deep.ot").string(), bt = (dir / "deep.bt").string();
  {
    std::ofstream out(ot, std::ios::binary);
    out << "# Octomap OcTree file\nid OcTree\nsize " << kNodes << "\nres 0.05\ndata\n";
    std::string record(5, '\0');
    const float value = 0.5f;
    std::memcpy(record.data(), &value, sizeof(value));
    for (long long k = 0; k < kNodes; ++k) {
      record[4] = k + 1 < kNodes ? '\x01' : '\0';  // child 0 is the next node
      out << record;
    }
  }
  {
    std::ofstream out(bt, std::ios::binary);
    out << "# Octomap OcTree binary file\nid OcTree\nsize " << kNodes << "\nres 0.05\ndata\n";
    for (long long k = 0; k < kNodes; ++k) {
      out << (k + 1 < kNodes ? '\x03' : '\x00') << '\0';  // 11: child 0 has children
    }
  }
  for (const std::string& path : {ot, bt}) {
    try {
      ReadOctoMap(path);
      ADD_FAILURE() << path << " accepted";
    } catch (const InputError& e) {
      EXPECT_TRUE(Contains(e.what(), path)) << e.what();
      EXPECT_TRUE(Contains(e.what(), "deeper than the tree's 16 levels")) << e.what();
    }
  }
  // A map with a voxel at the finest level (16 levels, the deepest valid nesting) reads back whole.
  octomap::OcTree tree(0.05);
  tree.updateNode(octomap::point3d(0.3f, -0.2f, 1.1f), true);
  tree.updateNode(octomap::point3d(-1.f, 0.4f, 0.2f), false);
  const std::string ot_ok = (dir / "ok.ot").string(), bt_ok = (dir / "ok.bt").string();
  ASSERT_TRUE(tree.write(ot_ok));
  ASSERT_TRUE(tree.writeBinary(bt_ok));
  EXPECT_EQ(ReadOctoMap(ot_ok)->size(), tree.size());
  EXPECT_GT(ReadOctoMap(bt_ok)->size(), 0u);
  // An empty tree has no node data and reads as empty.
  const std::string empty = (dir / "empty.bt").string(), empty_ot = (dir / "empty.ot").string();
  ASSERT_TRUE(octomap::OcTree(0.05).writeBinary(empty));
  ASSERT_TRUE(octomap::OcTree(0.05).write(empty_ot));
  EXPECT_EQ(ReadOctoMap(empty)->size(), 0u);
  EXPECT_EQ(ReadOctoMap(empty_ot)->size(), 0u);
  // A node count other than the header's is an error too.
  std::string bytes = testing::ReadAll(ot_ok);
  const size_t size_at = bytes.find("size ");
  ASSERT_NE(size_at, std::string::npos);
  bytes.replace(size_at, bytes.find('\n', size_at) - size_at, "size 3");
  const std::string ot_count = (dir / "count.ot").string();
  std::ofstream(ot_count, std::ios::binary) << bytes;
  try {
    ReadOctoMap(ot_count);
    ADD_FAILURE() << "a wrong node count accepted";
  } catch (const InputError& e) {
    EXPECT_TRUE(Contains(e.what(), "truncated or corrupt")) << e.what();
    EXPECT_TRUE(Contains(e.what(), "declares 3 nodes")) << e.what();
  }
}

}  // namespace
}  // namespace dygslam
