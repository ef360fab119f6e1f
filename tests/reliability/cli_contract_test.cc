// The bad-input contract of the command line (docs/command_line.md, "Bad input"):
// exit 1 with a message that names the file, line or option for bad input, exit 2 for usage
// errors, warnings on stderr that name file:line, never a signal or an "internal error".
// Most cases need no dataset (the error comes before the frames); the image and tracking cases
// build small datasets from generated images or from bonn_crowd_part.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string Config() { return std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml"; }

bool Contains(const std::string& text, const std::string& needle) {
  return text.find(needle) != std::string::npos;
}

int CountLines(const std::string& text) {
  int n = 0;
  for (char c : text) n += c == '\n';
  return n;
}

class CliContract : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(testing::DygslamBinary()))
      GTEST_SKIP() << "dygslam binary not built: " << testing::DygslamBinary();
    dir_ = testing::MakeTempDir("cli_contract");
  }
  testing::ProcessResult Run(const std::vector<std::string>& args) {
    return testing::RunDygslam(args, dir_);
  }
  // bonn.yaml plus `extra` lines, written to the scratch folder.
  std::string ConfigWith(const std::string& extra, const std::string& name = "settings.yaml") {
    const std::string path = (fs::path(dir_) / name).string();
    std::ofstream(path) << ReadAll(Config()) << extra;
    return path;
  }
  // A bad-input failure: exit 1, an "error:" message with every needle, no internal error.
  static void ExpectInputError(const testing::ProcessResult& r,
                               const std::vector<std::string>& needles) {
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_TRUE(Contains(r.err, "error:")) << r.err;
    EXPECT_FALSE(Contains(r.err, "internal error")) << r.err;
    for (const std::string& n : needles)
      EXPECT_TRUE(Contains(r.err, n)) << n << " not in\n" << r.err;
  }
  std::string dir_;
};

// SIGSEGV (rc 139) in `run` and `map` before the fix.
TEST_F(CliContract, RecursiveAliasInSettingsIsAnErrorInRunAndMap) {
  const int line = CountLines(ReadAll(Config())) + 1;
  const std::string config = ConfigWith("Tracking: &t {init_min_features: 300, self: *t}\n");
  for (const char* command : {"run", "map"}) {
    const auto r = Run({command, dir_, "--config", config, "--out", dir_ + "/out", "--quiet"});
    ExpectInputError(r, {config + ":" + std::to_string(line) + ":", "recursive alias"});
  }
}

// Unknown model fell back silently; misspelt keys were ignored without a word.
TEST_F(CliContract, SettingsMistakesAreErrorsOrWarningsWithFileAndLine) {
  const int line = CountLines(ReadAll(Config())) + 1;
  const std::string model = ConfigWith("Detector.model: yolo-nonexistent\n", "model.yaml");
  ExpectInputError(Run({"run", dir_, "--config", model, "--out", dir_ + "/out", "--direct"}),
                   {model + ":" + std::to_string(line) + ":", "Detector.model"});
  const std::string typo = ConfigWith("Camera.fxx: 500\n", "typo.yaml");
  // Warned, then the run goes on (and stops at the missing dataset: exit 1 for that).
  const auto warned =
      Run({"run", dir_ + "/missing", "--config", typo, "--out", dir_ + "/out", "--direct"});
  EXPECT_TRUE(Contains(warned.err, "warning: " + typo + ":" + std::to_string(line) +
                                       ": unknown key 'Camera.fxx' (did you mean 'Camera.fx'?)"))
      << warned.err;
  EXPECT_TRUE(Contains(warned.err, "dataset directory not found")) << warned.err;
  // --strict-settings makes it the error.
  const auto strict = Run({"run", dir_ + "/missing", "--config", typo, "--out", dir_ + "/out",
                           "--direct", "--strict-settings"});
  ExpectInputError(strict, {typo + ":" + std::to_string(line) + ":", "unknown key 'Camera.fxx'"});
  EXPECT_FALSE(Contains(strict.err, "dataset directory not found")) << strict.err;
}

// Accepted before; the run then "tracked" every frame on a ~1e-9 m trajectory.
TEST_F(CliContract, ImplausibleCameraValuesAreErrorsNamingKeyAndLine) {
  const std::string base = ReadAll(Config());
  const std::pair<std::string, std::string> cases[] = {
      {"Camera.fx: 542.822841", "Camera.fx: 1e308"},
      {"Camera.cx: 315.593520", "Camera.cx: -1000"},
      {"Camera.k1: 0.039903", "Camera.k1: 1e10"}};
  for (const auto& [line, replacement] : cases) {
    std::string text = base;
    const size_t at = text.find(line);
    ASSERT_NE(at, std::string::npos) << line;
    text.replace(at, line.size(), replacement);
    const std::string path = dir_ + "/camera.yaml";
    std::ofstream(path) << text;
    const std::string key = replacement.substr(0, replacement.find(':'));
    const auto r = Run({"run", dir_, "--config", path, "--out", dir_ + "/out", "--direct"});
    ExpectInputError(r, {path + ":" + std::to_string(CountLines(base.substr(0, at)) + 1) + ":",
                         "key '" + key + "'"});
  }
}

// "internal error: filesystem error" without naming --out, or found after the run.
TEST_F(CliContract, BadOutputFolderIsNamedBeforeTheRun) {
  std::ofstream(dir_ + "/a_file") << "x";
  for (const char* command : {"run", "map"}) {
    // An empty one is a usage error (exit 2), also before the dataset is looked at.
    const auto r = Run({command, dir_ + "/missing", "--config", Config(), "--out", ""});
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_TRUE(Contains(r.err, "option --out needs a value")) << r.err;
    EXPECT_FALSE(Contains(r.err, "dataset")) << r.err;
  }
  for (const std::string& out :
       {dir_ + "/a_file", std::string("/sys/kernel"), std::string("/proc/dygslam_no/out")}) {
    for (const char* command : {"run", "map"}) {
      // The dataset does not exist either: --out must be reported first.
      const auto r = Run({command, dir_ + "/missing", "--config", Config(), "--out", out});
      ExpectInputError(r, {"--out"});
      EXPECT_FALSE(Contains(r.err, "dataset")) << r.err;
    }
  }
}

// Exit 0 before the fix.
TEST_F(CliContract, SmallUsageErrorsExitTwo) {
  EXPECT_EQ(Run({"version", "extra"}).code, 2);
  EXPECT_EQ(Run({"help", "bogus"}).code, 2);
  EXPECT_EQ(Run({"help", "run"}).code, 0);
  EXPECT_EQ(Run({"version"}).code, 0);
  const auto security = Run({"run", dir_, "--direct", "--security", dir_, "--out", dir_ + "/out"});
  EXPECT_EQ(security.code, 2) << security.err;
  EXPECT_TRUE(Contains(security.err, "--security")) << security.err;
}

// `dygslam component` numbers are parsed whole (std::stoi / std::stod would throw, or read
// "1.5x" as 1.5): a bad one is a usage error naming the option, as on `dygslam run`.
TEST_F(CliContract, ComponentBadNumbersAreUsageErrorsNamingTheOption) {
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"window", "abc"},
      {"window", "-1"},
      {"domain", "233"},
      {"domain", "1e3"},
      {"rate", "1.5x"},
      {"loop-minutes", "-1"},
      {"detection-wait-ms", "99999999999999999999"}};
  for (const auto& [option, value] : bad) {
    const auto r = Run({"component", "player", "--dataset", dir_, "--config", Config(), "--out",
                        dir_ + "/out", "--" + option, value});
    EXPECT_EQ(r.code, 2) << option << " " << value << "\n" << r.err;
    EXPECT_TRUE(Contains(r.err, "--" + option + ": expected")) << r.err;
    EXPECT_TRUE(Contains(r.err, "'" + value + "'")) << r.err;
    EXPECT_FALSE(Contains(r.err, "internal error")) << r.err;
  }
}

// `eval` printed "rmse inf" (and null in JSON) with exit 0.
TEST_F(CliContract, EvalWithOverflowingCoordinatesFails) {
  std::ofstream gt(dir_ + "/gt.txt"), est(dir_ + "/est.txt");
  for (int i = 0; i < 20; ++i) {
    gt << 100 + 0.1 * i << " " << 0.01 * i << " 0 0 0 0 0 1\n";
    est << 100 + 0.1 * i << " " << (i % 2 ? 1e300 : -1e300) << " 0 0 0 0 0 1\n";
  }
  gt.close();
  est.close();
  for (const std::vector<std::string>& extra : {std::vector<std::string>{}, {"--json"}}) {
    std::vector<std::string> args = {"eval", dir_ + "/gt.txt", dir_ + "/est.txt"};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto r = Run(args);
    ExpectInputError(r, {dir_ + "/est.txt", "not a camera trajectory"});
    EXPECT_FALSE(Contains(r.out, "inf")) << r.out;
  }
}

// A dataset folder with `rgb` and `depth` lines (stamps 1.0, 1.033, ...; paths as given).
void WriteLists(const std::string& dir, const std::vector<std::string>& rgb,
                const std::vector<std::string>& depth, const std::string& rgb_prefix = "") {
  std::ofstream r(dir + "/rgb.txt"), d(dir + "/depth.txt");
  r << rgb_prefix;
  for (size_t i = 0; i < rgb.size(); ++i) r << 1.0 + 0.033 * i << " " << rgb[i] << "\n";
  for (size_t i = 0; i < depth.size(); ++i) d << 1.0 + 0.033 * i << " " << depth[i] << "\n";
}

// The 33-byte start of a PNG: signature and IHDR claiming width x height (no pixel data).
void WritePngHeader(const std::string& path, uint32_t width, uint32_t height) {
  unsigned char h[33] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n',
                         0,    0,   0,   13,  'I',  'H',  'D',  'R'};
  for (int i = 0; i < 4; ++i) {
    h[16 + i] = static_cast<unsigned char>(width >> (24 - 8 * i));
    h[20 + i] = static_cast<unsigned char>(height >> (24 - 8 * i));
  }
  h[24] = 8;  // bit depth
  h[25] = 2;  // RGB
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(h), sizeof(h));
}

// OpenCV assertion as "internal error" without the file or the rgb.txt line.
TEST_F(CliContract, HugePngIsRefusedFromItsHeaderNamingFileAndLine) {
  cv::imwrite(dir_ + "/depth.png", cv::Mat(480, 640, CV_16UC1, cv::Scalar(5000)));
  for (const uint32_t side : {65535u, 20000u}) {
    WritePngHeader(dir_ + "/huge.png", side, side);
    WriteLists(dir_, {"huge.png"}, {"depth.png"});
    const auto r =
        Run({"run", dir_, "--config", Config(), "--out", dir_ + "/out", "--direct", "--quiet"});
    const std::string size = std::to_string(side) + "x" + std::to_string(side);
    ExpectInputError(r, {dir_ + "/huge.png", dir_ + "/rgb.txt:1", size});
  }
}

// A link to /dev/zero or a FIFO was "not found"; list file and line were missing.
TEST_F(CliContract, ImagePathsThatAreNotRegularFilesAreNamed) {
  cv::imwrite(dir_ + "/depth.png", cv::Mat(480, 640, CV_16UC1, cv::Scalar(5000)));
  fs::create_symlink("/dev/zero", dir_ + "/zero.png");
  ASSERT_EQ(mkfifo((dir_ + "/fifo.png").c_str(), 0600), 0);
  fs::create_directories(dir_ + "/folder.png");
  const std::pair<std::string, std::string> cases[] = {
      {"zero.png", "a character device"}, {"fifo.png", "a FIFO"}, {"folder.png", "a directory"}};
  for (const auto& [name, kind] : cases) {
    WriteLists(dir_, {"depth.png", name}, {"depth.png", "depth.png"});
    const auto r = Run({"run", dir_, "--config", Config(), "--out", dir_ + "/out", "--direct"});
    ExpectInputError(r, {dir_ + "/rgb.txt:2", "not a regular file", kind});
  }
}

TEST_F(CliContract, ListFileDetailsAreNamedOrAccepted) {
  cv::imwrite(dir_ + "/depth.png", cv::Mat(480, 640, CV_16UC1, cv::Scalar(5000)));
  // A UTF-8 byte order mark: accepted.
  WriteLists(dir_, {"depth.png", "depth.png"}, {"depth.png", "depth.png"}, "\xEF\xBB\xBF");
  EXPECT_EQ(RgbdDataset::Open(dir_).size(), 2u);
  // A negative first timestamp: an error naming the line.
  {
    std::ofstream(dir_ + "/rgb.txt") << "-5.0 depth.png\n1.0 depth.png\n";
    try {
      RgbdDataset::Open(dir_);
      ADD_FAILURE() << "negative timestamp accepted";
    } catch (const InputError& e) {
      EXPECT_TRUE(Contains(e.what(), "rgb.txt:1:")) << e.what();
      EXPECT_TRUE(Contains(e.what(), "negative timestamp")) << e.what();
    }
  }
  // A 50 MB path: named, not echoed whole.
  {
    std::ofstream(dir_ + "/rgb.txt") << "1.0 " << std::string(50 << 20, 'a') << ".png\n";
    try {
      RgbdDataset::Open(dir_);
      ADD_FAILURE() << "50 MB path accepted";
    } catch (const InputError& e) {
      EXPECT_LT(std::string(e.what()).size(), 2000u);
      EXPECT_TRUE(Contains(e.what(), "rgb.txt:1:")) << std::string(e.what()).substr(0, 500);
    }
  }
  // A path outside the dataset folder: warned (default) or refused.
  fs::create_directories(dir_ + "/inner");
  cv::imwrite(dir_ + "/inner/depth.png", cv::Mat(480, 640, CV_16UC1, cv::Scalar(5000)));
  WriteLists(dir_ + "/inner", {"depth.png", "../depth.png"}, {"depth.png", "depth.png"});
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(RgbdDataset::Open(dir_ + "/inner").size(), 2u);
  const std::string warning = ::testing::internal::GetCapturedStderr();
  EXPECT_TRUE(Contains(warning,
                       "warning: " + dir_ + "/inner/rgb.txt:2: image path ../depth.png is outside"))
      << warning;
  DatasetOptions refuse;
  refuse.refuse_outside_paths = true;
  try {
    RgbdDataset::Open(dir_ + "/inner", refuse);
    ADD_FAILURE() << "outside path accepted";
  } catch (const InputError& e) {
    EXPECT_TRUE(Contains(e.what(), "rgb.txt:2:")) << e.what();
    EXPECT_TRUE(Contains(e.what(), "outside the dataset folder")) << e.what();
  }
  const auto r = Run({"run", dir_ + "/inner", "--config", Config(), "--out", dir_ + "/out",
                      "--direct", "--strict-paths"});
  ExpectInputError(r, {"rgb.txt:2:", "outside the dataset folder"});
}

// A run on depth images without any valid depth tracked nothing and exited 0.
TEST_F(CliContract, RunThatTracksNothingFailsWithASummary) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const RgbdDataset d = RgbdDataset::Open(source);
  cv::imwrite(dir_ + "/zero_depth.png", cv::Mat(480, 640, CV_16UC1, cv::Scalar(0)));
  std::vector<std::string> rgb, depth;
  for (size_t i = 0; i < 15; ++i) {
    rgb.push_back(d.frame(i).rgb_path);
    depth.push_back("zero_depth.png");
  }
  WriteLists(dir_, rgb, depth);
  const auto r = Run({"run", dir_, "--config", Config(), "--out", dir_ + "/out", "--direct",
                      "--filter", "none", "--quiet"});
  ExpectInputError(r, {"tracking failed: 0 of 15 frames tracked"});
  EXPECT_TRUE(Contains(r.out, "frames: 15 processed")) << r.out;
}

// `--out` = the dataset folder would let the recorder overwrite the dataset's groundtruth.txt
// (data loss); a settings file that is /dev/zero would be read until the memory ran out. Both are
// refused.
TEST_F(CliContract, OutputFolderThatIsADatasetIsRefusedAndNothingIsOverwritten) {
  const fs::path dataset = fs::path(dir_) / "dataset";
  fs::create_directories(dataset);
  const std::string groundtruth = "# ground truth\n1.0 0 0 0 0 0 0 1\n";
  std::ofstream(dataset / "rgb.txt") << "1.0 rgb/1.png\n";
  std::ofstream(dataset / "depth.txt") << "1.0 depth/1.png\n";
  std::ofstream(dataset / "groundtruth.txt") << groundtruth;
  for (const char* mode : {"--direct", "--processes"}) {
    const auto r = Run({"run", dataset.string(), "--config", Config(), "--out", dataset.string(),
                        "--quiet", mode});
    ExpectInputError(r, {"--out", "dataset folder"});
    EXPECT_EQ(ReadAll((dataset / "groundtruth.txt").string()), groundtruth) << mode;
  }
  const auto r = Run({"map", dataset.string(), "--config", Config(), "--out", dataset.string()});
  ExpectInputError(r, {"--out", "dataset folder"});
  // The components that write into --out, and the bridge's SLAM run.
  for (const char* component : {"recorder", "mapper", "pipeline"}) {
    const auto c = Run({"component", component, "--dataset", dataset.string(), "--config", Config(),
                        "--out", dataset.string()});
    ExpectInputError(c, {"--out", "dataset folder"});
  }
  const auto b = Run({"bridge", "--run-slam", "--config", Config(), "--out", dataset.string()});
  ExpectInputError(b, {"--out", "dataset folder"});
  EXPECT_EQ(ReadAll((dataset / "groundtruth.txt").string()), groundtruth);
}

TEST_F(CliContract, SettingsFileThatIsADeviceIsRefused) {
  const std::string link = (fs::path(dir_) / "zero.yaml").string();
  fs::create_symlink("/dev/zero", link);
  const auto r = Run({"run", dir_, "--config", link, "--out", dir_ + "/out", "--direct"});
  ExpectInputError(r, {link, "not a regular file"});
}

// A malformed --frames was exit 1; like every other malformed number it is a usage
// error (exit 2) naming the option.
TEST_F(CliContract, MalformedFrameRangeIsAUsageError) {
  DYGSLAM_REQUIRE_DATASET(dataset, "bonn_crowd_part");
  for (const char* command : {"run", "map"}) {
    for (const char* frames : {"5:abc", "-3:5", "0:99999999999999999999"}) {
      const auto r = Run({command, dataset, "--config", Config(), "--out", dir_ + "/out",
                          "--frames", frames, "--quiet"});
      EXPECT_EQ(r.code, 2) << command << " --frames " << frames << "\n" << r.err;
      EXPECT_TRUE(Contains(r.err, "--frames")) << r.err;
      EXPECT_FALSE(Contains(r.err, "internal error")) << r.err;
    }
  }
}

}  // namespace
}  // namespace dygslam
