#include "core/io/png_reader.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <vector>

#include "core/io/dataset.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {

bool Identical(const cv::Mat& a, const cv::Mat& b) {
  return a.type() == b.type() && a.size() == b.size() && cv::norm(a, b, cv::NORM_INF) == 0;
}

// Smooth gradients plus noise: the encoder picks different row filters (sub, up, average, Paeth)
// on different rows.
cv::Mat Pattern(int type, uint32_t seed) {
  cv::Mat m(97, 131, type);
  std::mt19937 rng(seed);
  const int channels = m.channels();
  const bool wide = m.depth() == CV_16U;
  for (int y = 0; y < m.rows; ++y) {
    for (int x = 0; x < m.cols; ++x) {
      for (int c = 0; c < channels; ++c) {
        const int value = (x * (c + 1) + y * 3 + int(rng() % 7)) * (wide ? 257 : 1);
        if (wide)
          m.ptr<uint16_t>(y)[x * channels + c] = uint16_t(value % 65536);
        else
          m.ptr<uint8_t>(y)[x * channels + c] = uint8_t(value % 256);
      }
    }
  }
  return m;
}

std::vector<unsigned char> Encode(const cv::Mat& m, int strategy, int level) {
  std::vector<unsigned char> bytes;
  cv::imencode(".png", m, bytes,
               {cv::IMWRITE_PNG_STRATEGY, strategy, cv::IMWRITE_PNG_COMPRESSION, level});
  return bytes;
}

TEST(PngReader, SamePixelsAsOpenCvOnGeneratedImages) {
  if (!FastPngAvailable()) GTEST_SKIP() << "built without libdeflate";
  int compared = 0;
  for (int type : {CV_8UC1, CV_8UC3, CV_8UC4, CV_16UC1}) {
    for (int strategy : {cv::IMWRITE_PNG_STRATEGY_DEFAULT, cv::IMWRITE_PNG_STRATEGY_FILTERED,
                         cv::IMWRITE_PNG_STRATEGY_RLE}) {
      for (int level : {0, 1, 9}) {
        const cv::Mat m = Pattern(type, 7u * type + strategy + 31u * level);
        const std::vector<unsigned char> bytes = Encode(m, strategy, level);
        cv::Mat fast;
        ASSERT_TRUE(DecodePngFast(bytes.data(), bytes.size(), &fast))
            << "type " << type << " strategy " << strategy << " level " << level;
        const cv::Mat reference = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
        EXPECT_TRUE(Identical(fast, reference))
            << "type " << type << " strategy " << strategy << " level " << level;
        EXPECT_TRUE(Identical(fast, m));
        ++compared;
      }
    }
  }
  EXPECT_EQ(compared, 36);
}

TEST(PngReader, DeclinesWhatItDoesNotHandleOrWhatIsDamaged) {
  if (!FastPngAvailable()) GTEST_SKIP() << "built without libdeflate";
  const cv::Mat m = Pattern(CV_8UC3, 3);
  const std::vector<unsigned char> good = Encode(m, cv::IMWRITE_PNG_STRATEGY_DEFAULT, 3);
  cv::Mat out;
  ASSERT_TRUE(DecodePngFast(good.data(), good.size(), &out));

  // A flipped bit in the pixel data: the chunk CRC no longer matches.
  std::vector<unsigned char> flipped = good;
  flipped[good.size() / 2] ^= 0x10;
  cv::Mat untouched;
  EXPECT_FALSE(DecodePngFast(flipped.data(), flipped.size(), &untouched));
  EXPECT_TRUE(untouched.empty());
  // Truncated: no IEND.
  EXPECT_FALSE(DecodePngFast(good.data(), good.size() - 20, &untouched));
  // Not a PNG.
  const std::vector<unsigned char> text(100, 'x');
  EXPECT_FALSE(DecodePngFast(text.data(), text.size(), &untouched));
  // 16-bit colour: left to OpenCV.
  const std::vector<unsigned char> rgb16 =
      Encode(Pattern(CV_16UC3, 5), cv::IMWRITE_PNG_STRATEGY_DEFAULT, 3);
  EXPECT_FALSE(DecodePngFast(rgb16.data(), rgb16.size(), &untouched));
  // 1-bit (bilevel): left to OpenCV.
  std::vector<unsigned char> bilevel;
  cv::imencode(".png", Pattern(CV_8UC1, 9) > 128, bilevel, {cv::IMWRITE_PNG_BILEVEL, 1});
  EXPECT_FALSE(DecodePngFast(bilevel.data(), bilevel.size(), &untouched));
  EXPECT_TRUE(untouched.empty());
}

// A header asking for far more pixels than the IDAT data could hold (deflate expands at most
// 1032:1) is declined before the decoder allocates the image; images that compress as well as
// deflate allows (all zero, level 9) still decode.
TEST(PngReader, DeclinesImpossibleSizesAndKeepsMaximallyCompressedImages) {
  if (!FastPngAvailable()) GTEST_SKIP() << "built without libdeflate";
  for (int type : {CV_16UC1, CV_8UC4}) {
    const cv::Mat zeros = cv::Mat::zeros(type == CV_16UC1 ? 480 : 1500, 640, type);
    const std::vector<unsigned char> bytes = Encode(zeros, cv::IMWRITE_PNG_STRATEGY_DEFAULT, 9);
    cv::Mat out;
    ASSERT_TRUE(DecodePngFast(bytes.data(), bytes.size(), &out)) << "type " << type;
    EXPECT_EQ(cv::countNonZero(out.reshape(1)), 0);
  }
  // A 1x1 grey PNG whose IHDR then claims 16384x16384 RGBA (CRC fixed up).
  std::vector<unsigned char> bytes =
      Encode(cv::Mat(1, 1, CV_8UC1, cv::Scalar(9)), cv::IMWRITE_PNG_STRATEGY_DEFAULT, 9);
  ASSERT_EQ(std::string(bytes.begin() + 12, bytes.begin() + 16), "IHDR");
  const unsigned char header[] = {0, 0, 0x40, 0, 0, 0, 0x40, 0, 8, 6};
  std::copy(header, header + sizeof(header), bytes.begin() + 16);
  uint32_t crc = 0xffffffffu;  // CRC-32 of type + body (17 bytes)
  for (size_t i = 12; i < 12 + 17; ++i) {
    crc ^= bytes[i];
    for (int k = 0; k < 8; ++k) crc = (crc & 1) ? 0xedb88320u ^ (crc >> 1) : crc >> 1;
  }
  crc ^= 0xffffffffu;
  for (int k = 0; k < 4; ++k) bytes[29 + k] = uint8_t(crc >> (24 - 8 * k));
  cv::Mat untouched;
  EXPECT_FALSE(DecodePngFast(bytes.data(), bytes.size(), &untouched));
  EXPECT_TRUE(untouched.empty());
}

TEST(PngReader, DatasetImagesIdenticalToOpenCv) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  if (!FastPngAvailable()) GTEST_SKIP() << "built without libdeflate";
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  // Every 12th frame: 30 rgb + 30 depth images (all 360 take ~10 s with OpenCV as reference).
  int compared = 0;
  for (size_t k = 0; k < dataset.size(); k += 12) {
    for (const std::string& path : {dataset.frame(k).rgb_path, dataset.frame(k).depth_path}) {
      cv::Mat fast;
      ASSERT_TRUE(ReadPngFast(path, &fast)) << path;
      EXPECT_TRUE(Identical(fast, cv::imread(path, cv::IMREAD_UNCHANGED))) << path;
      ++compared;
    }
  }
  EXPECT_EQ(compared, 60);
}

}  // namespace
}  // namespace dygslam
