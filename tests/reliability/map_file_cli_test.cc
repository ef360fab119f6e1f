// `dygslam run --load-map` with a damaged or foreign map file: truncated at 10
// offsets, flipped bytes, another format version, another camera. Each gives its clear error
// naming the file (exit 1) before any work, and leaves no output file (not even a half-written
// one) in --out. A good map localizes from the first frame.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

std::string ReadBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void WriteBytes(const fs::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

std::string Config(const std::string& name) {
  return std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/" + name;
}

TEST(MapFileCli, DamagedOrForeignMapIsAClearErrorWithNoOutput) {
  DYGSLAM_REQUIRE_DATASET(data, "bonn_crowd_part");
  DYGSLAM_REQUIRE_FILE(testing::DygslamBinary(), "dygslam binary");
  const fs::path dir = testing::MakeTempDir("map_file_cli");
  const fs::path good = dir / "good.dygmap";
  // A small map: 20 frames, no detector (filter none), no OctoMap.
  const testing::ProcessResult made =
      testing::RunDygslam({"run", data, "--config", Config("bonn.yaml"), "--frames", "0:20",
                           "--direct", "--deterministic", "--filter", "none", "--no-map", "--quiet",
                           "--out", (dir / "mapping").string(), "--save-map", good.string()},
                          dir.string());
  ASSERT_EQ(made.code, 0) << made.err;
  const std::string bytes = ReadBytes(good);
  ASSERT_GT(bytes.size(), 10000u);

  struct Case {
    std::string name, bytes, config, expected;
  };
  std::vector<Case> cases;
  for (int k = 0; k < 10; ++k) {
    const size_t cut = k == 0 ? 12 : k * (bytes.size() / 10) + (k == 9 ? bytes.size() / 10 - 1 : 0);
    cases.push_back({"truncated at " + std::to_string(cut), bytes.substr(0, cut), "bonn.yaml",
                     "truncated map file"});
  }
  for (size_t offset : {size_t(40), bytes.size() / 2, bytes.size() - 3}) {
    std::string bad = bytes;
    bad[offset] = static_cast<char>(bad[offset] ^ 0x01);
    cases.push_back(
        {"flipped byte at " + std::to_string(offset), bad, "bonn.yaml", "checksum mismatch"});
  }
  {
    std::string bad = bytes;
    bad[8] = 9;
    cases.push_back(
        {"version 9", bad, "bonn.yaml", "format version 9, this build reads versions 1 to 3"});
  }
  cases.push_back({"other camera", bytes, "tum1.yaml", "different camera: Camera.fx"});

  for (size_t i = 0; i < cases.size(); ++i) {
    const Case& c = cases[i];
    const fs::path map = dir / ("bad" + std::to_string(i) + ".dygmap");
    WriteBytes(map, c.bytes);
    const fs::path out = dir / ("out" + std::to_string(i));
    const testing::ProcessResult r = testing::RunDygslam(
        {"run", data, "--config", Config(c.config), "--frames", "0:20", "--direct", "--filter",
         "none", "--quiet", "--out", out.string(), "--load-map", map.string(), "--localization",
         "--save-map", (out / "again.dygmap").string()},
        dir.string());
    EXPECT_EQ(r.code, 1) << c.name << ": " << r.err;
    EXPECT_NE(r.err.find(map.string()), std::string::npos) << c.name << ": " << r.err;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << c.name << ": " << r.err;
    EXPECT_EQ(r.err.find("internal error"), std::string::npos) << c.name;
    // No output at all (the folder may exist, empty): nothing half-written.
    if (fs::exists(out)) EXPECT_TRUE(fs::is_empty(out)) << c.name;
  }

  // --localization without a map is a usage error.
  const testing::ProcessResult usage = testing::RunDygslam(
      {"run", data, "--direct", "--localization", "--out", (dir / "usage").string()}, dir.string());
  EXPECT_EQ(usage.code, 2) << usage.err;

  // The good map: the first frame is relocalized in it (not lost), and nothing is added.
  const fs::path out = dir / "localization";
  const testing::ProcessResult ok =
      testing::RunDygslam({"run", data, "--config", Config("bonn.yaml"), "--frames", "0:20",
                           "--direct", "--deterministic", "--filter", "none", "--no-map", "--quiet",
                           "--out", out.string(), "--load-map", good.string(), "--localization"},
                          dir.string());
  ASSERT_EQ(ok.code, 0) << ok.err;
  std::ifstream csv(out / "frames.csv");
  std::string header, first;
  std::getline(csv, header);
  std::getline(csv, first);
  EXPECT_NE(first.find(",relocalized,"), std::string::npos) << first;
}

// The DDS pipeline (one process and --processes): --save-map writes the SLAM map and map.ot at the
// end; a second run with --load-map --localization --load-octomap localizes from the first frame,
// the slam component announces the loaded map, nothing is added to it, and the static map of the
// localization run is the loaded OctoMap.
class MapFileDds : public ::testing::TestWithParam<std::string> {};

TEST_P(MapFileDds, SaveThenLocalizeWithTheLoadedMaps) {
  DYGSLAM_REQUIRE_DATASET(data, "bonn_crowd_part");
  DYGSLAM_REQUIRE_FILE(testing::DygslamBinary(), "dygslam binary");
  const fs::path dir = testing::MakeTempDir("map_file_dds");
  const fs::path map = dir / "crowd.dygmap";
  auto run = [&](const std::string& name, std::vector<std::string> extra) {
    std::vector<std::string> args = {"run",
                                     data,
                                     "--config",
                                     Config("bonn.yaml"),
                                     "--frames",
                                     "0:60",
                                     "--deterministic",
                                     "--filter",
                                     "none",
                                     "--domain",
                                     "132",
                                     "--out",
                                     (dir / name).string()};
    if (!GetParam().empty()) args.push_back(GetParam());
    args.insert(args.end(), extra.begin(), extra.end());
    return testing::RunDygslam(args, dir.string());
  };
  const testing::ProcessResult made = run("mapping", {"--save-map", map.string()});
  ASSERT_EQ(made.code, 0) << made.err;
  ASSERT_TRUE(fs::exists(map)) << made.err;
  ASSERT_TRUE(fs::exists(dir / "mapping" / "map.ot")) << made.err;
  const std::string map_bytes = ReadBytes(map);

  const testing::ProcessResult loc =
      run("localization",
          {"--load-map", map.string(), "--localization", "--load-octomap",
           (dir / "mapping" / "map.ot").string(), "--save-map", (dir / "again.dygmap").string()});
  ASSERT_EQ(loc.code, 0) << loc.err;
  const std::string all = loc.out + loc.err;
  EXPECT_NE(all.find("started from map file " + map.string()), std::string::npos) << all;
  // Every frame has a pose, the first one relocalized in the loaded map.
  std::ifstream csv(dir / "localization" / "frames.csv");
  std::string line;
  std::getline(csv, line);
  int rows = 0, with_pose = 0;
  std::string first;
  while (std::getline(csv, line)) {
    if (rows++ == 0) first = line;
    with_pose += line.find(",ok,") != std::string::npos ||
                 line.find(",relocalized,") != std::string::npos ||
                 line.find(",fallback,") != std::string::npos;
  }
  EXPECT_EQ(rows, 60);
  EXPECT_EQ(with_pose, 60);
  EXPECT_NE(first.find(",relocalized,"), std::string::npos) << first;
  // Localization adds nothing: the map saved again is the loaded one, byte for byte, and the
  // static map is the loaded OctoMap.
  EXPECT_TRUE(ReadBytes(dir / "again.dygmap") == map_bytes);
  EXPECT_TRUE(ReadBytes(dir / "localization" / "map.bt") == ReadBytes(dir / "mapping" / "map.bt"));
}

INSTANTIATE_TEST_SUITE_P(Modes, MapFileDds, ::testing::Values("", "--processes"),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           return info.param.empty() ? std::string("OneProcess")
                                                     : std::string("Processes");
                         });

}  // namespace
}  // namespace dygslam
