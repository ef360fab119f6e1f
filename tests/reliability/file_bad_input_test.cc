// Bad files on disk: truncated / corrupt / oddly encoded PNGs, absurd PNG headers, depth lists with
// holes, settings with non-finite values or garbage. Each gives an InputError naming the file
// (and line / key where there is one), or a documented, counted skip -- never a crash.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/config/settings.h"
#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "run/settings_table.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

void WriteBytes(const fs::path& path, const std::vector<uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}
std::vector<uint8_t> ReadBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), {});
}
void WriteText(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

uint32_t Crc32(const uint8_t* data, size_t n) {
  uint32_t c = 0xffffffffu;
  for (size_t i = 0; i < n; ++i) {
    c ^= data[i];
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
  }
  return c ^ 0xffffffffu;
}
void PutBe32(std::vector<uint8_t>* b, size_t at, uint32_t v) {
  for (int k = 0; k < 4; ++k) (*b)[at + k] = static_cast<uint8_t>(v >> (24 - 8 * k));
}

// A TUM-layout folder of `n` noise frames (640x480), rgb at 30 Hz, depth 5 ms later.
class FileBadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::MakeTempDir("reliability_files");
    fs::create_directories(dir_ / "rgb");
    fs::create_directories(dir_ / "depth");
    cv::RNG rng(7);
    std::string rgb_list, depth_list;
    for (int i = 0; i < 6; ++i) {
      const std::string rt = "200." + std::to_string(100 + 33 * i) + "000";
      const std::string dt = "200." + std::to_string(105 + 33 * i) + "000";
      // Smooth random content (noise upsampled): realistic PNG sizes, quick to compress.
      cv::Mat small_rgb(60, 80, CV_8UC3), small_depth(60, 80, CV_16UC1), rgb, depth;
      rng.fill(small_rgb, cv::RNG::UNIFORM, 0, 255);
      rng.fill(small_depth, cv::RNG::UNIFORM, 2000, 20000);
      cv::resize(small_rgb, rgb, cv::Size(640, 480), 0, 0, cv::INTER_LINEAR);
      cv::resize(small_depth, depth, cv::Size(640, 480), 0, 0, cv::INTER_LINEAR);
      cv::imwrite((dir_ / "rgb" / (rt + ".png")).string(), rgb);
      cv::imwrite((dir_ / "depth" / (dt + ".png")).string(), depth);
      rgb_list += rt + " rgb/" + rt + ".png\n";
      depth_list += dt + " depth/" + dt + ".png\n";
      depth_lines_.push_back(dt + " depth/" + dt + ".png\n");
    }
    WriteText(dir_ / "rgb.txt", rgb_list);
    WriteText(dir_ / "depth.txt", depth_list);
  }
  // Expects LoadRgb/LoadDepth(i) to throw an InputError naming the file and containing `what`.
  template <class Fn>
  void ExpectFileError(Fn fn, const std::string& path, const std::string& what) {
    try {
      fn();
      ADD_FAILURE() << "expected InputError for " << path;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  }
  fs::path dir_;
  std::vector<std::string> depth_lines_;
};

TEST_F(FileBadInput, TruncatedPngsAreDecodeErrorsNamingTheFile) {
  const RgbdDataset d = RgbdDataset::Open(dir_.string());
  const std::vector<uint8_t> rgb = ReadBytes(d.frame(0).rgb_path);
  const std::vector<uint8_t> depth = ReadBytes(d.frame(0).depth_path);
  ASSERT_GT(rgb.size(), 50000u);
  // Cut inside the signature, the header, the image data (early, middle, just before the end).
  for (size_t keep :
       {size_t{0}, size_t{5}, size_t{30}, size_t{200}, rgb.size() / 2, rgb.size() - 40}) {
    WriteBytes(d.frame(1).rgb_path, std::vector<uint8_t>(rgb.begin(), rgb.begin() + keep));
    ExpectFileError([&] { d.LoadRgb(1, 640, 480); }, d.frame(1).rgb_path, "rgb");
  }
  for (size_t keep : {size_t{8}, depth.size() / 3, depth.size() - 40}) {
    WriteBytes(d.frame(1).depth_path, std::vector<uint8_t>(depth.begin(), depth.begin() + keep));
    ExpectFileError([&] { d.LoadDepth(1, 640, 480); }, d.frame(1).depth_path, "depth");
  }
  // The other frames are unaffected.
  EXPECT_EQ(d.LoadRgb(2, 640, 480).size(), cv::Size(640, 480));
}

TEST_F(FileBadInput, CorruptPngDataIsADecodeError) {
  const RgbdDataset d = RgbdDataset::Open(dir_.string());
  std::vector<uint8_t> rgb = ReadBytes(d.frame(0).rgb_path);
  // Flip bytes in the middle of the compressed data (the chunk CRC no longer matches).
  for (size_t k = rgb.size() / 2; k < rgb.size() / 2 + 64; ++k) rgb[k] ^= 0x5a;
  WriteBytes(d.frame(0).rgb_path, rgb);
  ExpectFileError([&] { d.LoadRgb(0, 640, 480); }, d.frame(0).rgb_path, "cannot decode");
  // Random bytes with a valid PNG signature.
  std::vector<uint8_t> junk = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  for (int k = 0; k < 5000; ++k) junk.push_back(static_cast<uint8_t>(k * 131 + 7));
  WriteBytes(d.frame(1).depth_path, junk);
  ExpectFileError([&] { d.LoadDepth(1, 640, 480); }, d.frame(1).depth_path, "cannot decode");
  // An empty file.
  WriteBytes(d.frame(2).rgb_path, {});
  ExpectFileError([&] { d.LoadRgb(2, 640, 480); }, d.frame(2).rgb_path, "rgb");
}

TEST_F(FileBadInput, AbsurdPngHeaderIsRejectedWithoutAllocating) {
  const RgbdDataset d = RgbdDataset::Open(dir_.string());
  std::vector<uint8_t> png = ReadBytes(d.frame(0).depth_path);
  // IHDR starts at byte 8: length(4) "IHDR"(4) width(4) height(4) ... crc(4) at 29.
  ASSERT_EQ(std::string(png.begin() + 12, png.begin() + 16), "IHDR");
  for (auto [w, h] : {std::pair<uint32_t, uint32_t>{0x7fffffffu, 0x7fffffffu},
                      {1u << 20, 1u << 20},
                      {0u, 480u}}) {
    PutBe32(&png, 16, w);
    PutBe32(&png, 20, h);
    PutBe32(&png, 29, Crc32(png.data() + 12, 17));  // a valid chunk: only the values are absurd
    WriteBytes(d.frame(0).depth_path, png);
    ExpectFileError([&] { d.LoadDepth(0, 640, 480); }, d.frame(0).depth_path, "depth");
  }
}

TEST_F(FileBadInput, WrongEncodingsNameExpectedAndFoundType) {
  const RgbdDataset d = RgbdDataset::Open(dir_.string());
  // 16-bit colour, RGBA, grey where colour is expected; colour and float where depth is expected.
  cv::imwrite(d.frame(0).rgb_path, cv::Mat(480, 640, CV_16UC3, cv::Scalar(1000, 2000, 3000)));
  ExpectFileError([&] { d.LoadRgb(0, 640, 480); }, d.frame(0).rgb_path, "must be");
  cv::imwrite(d.frame(1).rgb_path, cv::Mat(480, 640, CV_8UC4, cv::Scalar(1, 2, 3, 4)));
  ExpectFileError([&] { d.LoadRgb(1, 640, 480); }, d.frame(1).rgb_path, "must be");
  cv::imwrite(d.frame(2).rgb_path, cv::Mat(480, 640, CV_8UC1, cv::Scalar(9)));
  ExpectFileError([&] { d.LoadRgb(2, 640, 480); }, d.frame(2).rgb_path, "must be");
  cv::imwrite(d.frame(3).depth_path, cv::Mat(480, 640, CV_8UC3, cv::Scalar(9, 9, 9)));
  ExpectFileError([&] { d.LoadDepth(3, 640, 480); }, d.frame(3).depth_path, "must be");
  // Wrong size (another camera's images mixed in).
  cv::imwrite(d.frame(4).depth_path, cv::Mat(240, 320, CV_16UC1, cv::Scalar(5000)));
  ExpectFileError([&] { d.LoadDepth(4, 640, 480); }, d.frame(4).depth_path, "320x240");
}

// Holes in depth.txt (frames the sensor dropped): those rgb entries have no partner and are
// counted, not silently paired with a far-away depth image.
TEST_F(FileBadInput, MissingDepthEntriesLeaveRgbUnmatched) {
  std::string depth_list;
  for (size_t i = 0; i < depth_lines_.size(); ++i) {
    if (i != 2 && i != 3) depth_list += depth_lines_[i];
  }
  WriteText(dir_ / "depth.txt", depth_list);
  const RgbdDataset d = RgbdDataset::Open(dir_.string());
  EXPECT_EQ(d.num_rgb_entries(), 6u);
  EXPECT_EQ(d.size(), 4u);
  EXPECT_FALSE(d.FrameForRgbEntry(2).has_value());
  EXPECT_FALSE(d.FrameForRgbEntry(3).has_value());
  for (const RgbdFrameEntry& f : d.frames()) {
    EXPECT_LT(std::abs(SecondsBetween(f.rgb_stamp, f.depth_stamp)), 0.02);
  }
  // An empty depth list: every entry unmatched, and Open says so or yields no frames.
  WriteText(dir_ / "depth.txt", "# nothing\n");
  try {
    const RgbdDataset empty = RgbdDataset::Open(dir_.string());
    EXPECT_EQ(empty.size(), 0u);
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("depth"), std::string::npos) << e.what();
  }
}

TEST_F(FileBadInput, BinaryGarbageListFileNamesFileAndLine) {
  std::string garbage = "100.0 rgb/x.png\n";
  for (int k = 0; k < 300; ++k) garbage.push_back(static_cast<char>((k * 97 + 13) & 0xff));
  WriteText(dir_ / "rgb.txt", garbage);
  try {
    RgbdDataset::Open(dir_.string());
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("rgb.txt:"), std::string::npos) << e.what();
  }
}

TEST(SettingsBadInput, NonFiniteAndGarbageValuesNameFileAndKey) {
  const std::string base =
      "Camera.fx: 500\nCamera.fy: 500\nCamera.cx: 320\nCamera.cy: 240\n"
      "Camera.k1: 0\nCamera.k2: 0\nCamera.p1: 0\nCamera.p2: 0\n";
  ASSERT_NO_THROW(ParseSettings(base, "ok.yaml"));
  struct Case {
    std::string text, key;
  };
  const std::vector<Case> cases = {
      {"Camera.fx: .nan\n", "Camera.fx"},
      {"Camera.bf: -.inf\n", "Camera.bf"},
      {"ThDepth: .inf\n", "ThDepth"},
      {"Camera.fps: nan\n", "Camera.fps"},
      {"Camera.width: 1e12\n", "Camera.width"},
      {"Camera.height: -480\n", "Camera.height"},
      {"ORBextractor.nFeatures: 2.5\n", "ORBextractor.nFeatures"},
      {"ORBextractor.scaleFactor: 1e400\n", "ORBextractor.scaleFactor"},
      {"DepthMapFactor: 0\n", "DepthMapFactor"},
      {"Camera.k3: [1, 2]\n", "Camera.k3"},
  };
  for (const Case& c : cases) {
    // Replace the key when it is one of the required ones, else append.
    std::string text = base;
    const auto at = text.find(c.key + ":");
    if (at != std::string::npos) text.erase(at, text.find('\n', at) - at + 1);
    text += c.text;
    try {
      ParseSettings(text, "bad.yaml");
      ADD_FAILURE() << "accepted " << c.text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("bad.yaml:"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(c.key), std::string::npos) << e.what();
    }
  }
}

TEST(SettingsBadInput, MalformedYamlIsAnInputError) {
  const std::vector<std::string> texts = {
      "Camera.fx: [500\n",
      "Camera: {fx: 500\n",
      "\t\tCamera.fx 500\n: :\n",
      std::string(100000, '['),  // deep nesting
      std::string("Camera.fx: 500\n") + std::string("\0\1\2\3\xff\xfe", 6),
      "%YAML:1.0\n---\n- a\n- b\n",  // a sequence, not a map
  };
  for (const std::string& t : texts) {
    EXPECT_THROW(ParseSettings(t, "malformed.yaml"), InputError) << t.substr(0, 40);
  }
}

TEST(TrajectoryBadInput, NonFinitePosesAreRejectedOnReadAndWrite) {
  const fs::path dir = testing::MakeTempDir("reliability_traj");
  const std::vector<std::string> bad = {
      "1.0 nan 0 0 0 0 0 1\n",
      "1.0 0 0 0 0 0 0 inf\n",
      "1.0 0 0 0 0 0 0 0\n",
      "1.0 1e400 0 0 0 0 0 1\n",
      // Stamps beyond int64 nanoseconds (found by trajectory_fuzzer: signed overflow).
      "15483398238.98123 0 0 0 0 0 0 1\n",
      "99999999999999999999 0 0 0 0 0 0 1\n",
  };
  for (const std::string& line : bad) {
    WriteText(dir / "t.txt", "0.5 0 0 0 0 0 0 1\n" + line);
    SCOPED_TRACE(line);
    try {
      ReadTumTrajectory((dir / "t.txt").string());
      ADD_FAILURE() << "accepted " << line;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("t.txt:2"), std::string::npos) << e.what();
    }
  }
  std::vector<StampedPose> poses(1);
  poses[0].world_from_cam.translation.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_ANY_THROW(WriteTumTrajectory((dir / "out.txt").string(), poses));
  EXPECT_FALSE(fs::exists(dir / "out.txt"));
}

}  // namespace
}  // namespace dygslam
