// libFuzzer target: the dataset player's own PNG decoder, DecodePngFast (core/io/png_reader.h),
// on corrupt, truncated and odd-layout PNGs. Contract: it returns false and leaves the image
// untouched, or it returns true with exactly what cv::imdecode(IMREAD_UNCHANGED) gives for the
// same bytes (type, size, every pixel); it never reads out of bounds (ASan) or crashes.
//
// The first input byte picks how the rest becomes a PNG (mutations of a plain file rarely get
// past the chunk CRCs and the zlib checksum):
//   mode 0  the rest as is
//   mode 1  the rest with every chunk's CRC recomputed (header fields, chunk order and lengths)
//   mode 2  a PNG built around the rest: width, height (1..64), bit depth, colour type, then the
//           filtered rows (filter bytes included, cut or zero-padded to the exact size), stored in
//           a valid zlib stream: reaches the row unfiltering with any filter bytes
#include <array>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <opencv2/core.hpp>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "core/io/png_reader.h"

namespace {

using Bytes = std::vector<unsigned char>;

uint32_t Crc32(const unsigned char* data, size_t size) {
  static const std::array<uint32_t, 256> table = [] {
    std::array<uint32_t, 256> t{};
    for (uint32_t n = 0; n < 256; ++n) {
      uint32_t c = n;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xedb88320u ^ (c >> 1) : c >> 1;
      t[n] = c;
    }
    return t;
  }();
  uint32_t c = 0xffffffffu;
  for (size_t i = 0; i < size; ++i) c = table[(c ^ data[i]) & 0xff] ^ (c >> 8);
  return c ^ 0xffffffffu;
}

void PutBigEndian32(uint32_t v, unsigned char* p) {
  p[0] = uint8_t(v >> 24);
  p[1] = uint8_t(v >> 16);
  p[2] = uint8_t(v >> 8);
  p[3] = uint8_t(v);
}

uint32_t BigEndian32(const unsigned char* p) {
  return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | uint32_t(p[3]);
}

void AppendChunk(const char* type, const Bytes& body, Bytes* png) {
  unsigned char word[4];
  PutBigEndian32(uint32_t(body.size()), word);
  png->insert(png->end(), word, word + 4);
  const size_t type_at = png->size();
  png->insert(png->end(), type, type + 4);
  png->insert(png->end(), body.begin(), body.end());
  PutBigEndian32(Crc32(png->data() + type_at, body.size() + 4), word);
  png->insert(png->end(), word, word + 4);
}

// Mode 1: walks the chunks as a PNG reader does and rewrites each complete chunk's CRC.
Bytes WithRepairedCrcs(Bytes png) {
  size_t pos = 8;
  while (pos + 12 <= png.size()) {
    const uint32_t length = BigEndian32(png.data() + pos);
    if (length > png.size() - pos - 12) break;
    PutBigEndian32(Crc32(png.data() + pos + 4, size_t(length) + 4), png.data() + pos + 8 + length);
    pos += 12 + size_t(length);
  }
  return png;
}

// Mode 2: a PNG around fuzzed rows, the zlib stream made of stored (uncompressed) deflate blocks.
Bytes BuiltPng(const unsigned char* data, size_t size) {
  if (size < 4) return {};
  const uint32_t width = 1 + data[0] % 64, height = 1 + data[1] % 64;
  static const int kDepths[] = {1, 2, 4, 8, 16};
  static const int kColourTypes[] = {0, 2, 3, 4, 6};
  const int bit_depth = kDepths[data[2] % 5], colour_type = kColourTypes[data[3] % 5];
  const int samples[] = {1, 0, 3, 1, 2, 0, 4};
  const size_t row_bits = size_t(width) * samples[colour_type] * bit_depth;
  Bytes raw(data + 4, data + size);
  raw.resize(height * (1 + (row_bits + 7) / 8), 0);

  Bytes zlib = {0x78, 0x01};
  size_t at = 0;
  do {
    const size_t n = std::min<size_t>(raw.size() - at, 65535);
    const bool last = at + n == raw.size();
    zlib.push_back(last ? 1 : 0);
    zlib.push_back(uint8_t(n));
    zlib.push_back(uint8_t(n >> 8));
    zlib.push_back(uint8_t(~n));
    zlib.push_back(uint8_t(~n >> 8));
    zlib.insert(zlib.end(), raw.begin() + at, raw.begin() + at + n);
    at += n;
  } while (at < raw.size());
  uint32_t a = 1, b = 0;  // Adler-32
  for (unsigned char c : raw) {
    a = (a + c) % 65521;
    b = (b + a) % 65521;
  }
  unsigned char word[4];
  PutBigEndian32((b << 16) | a, word);
  zlib.insert(zlib.end(), word, word + 4);

  Bytes png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  Bytes header(13, 0);
  PutBigEndian32(width, header.data());
  PutBigEndian32(height, header.data() + 4);
  header[8] = uint8_t(bit_depth);
  header[9] = uint8_t(colour_type);
  AppendChunk("IHDR", header, &png);
  AppendChunk("IDAT", zlib, &png);
  AppendChunk("IEND", {}, &png);
  return png;
}

void Check(const Bytes& png) {
  static const bool quiet = [] {
    cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
    return true;
  }();
  (void)quiet;
  const cv::Mat sentinel(1, 1, CV_8UC1, cv::Scalar(77));
  cv::Mat fast = sentinel;
  if (!dygslam::DecodePngFast(png.data(), png.size(), &fast)) {
    // Untouched: the caller falls back to OpenCV.
    if (fast.data != sentinel.data || fast.rows != 1 || fast.cols != 1) std::abort();
    return;
  }
  cv::Mat reference;
  try {
    reference = cv::imdecode(png, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception&) {
  }
  // Accepted by the fast path: OpenCV must decode the same pixels.
  if (reference.empty() || reference.type() != fast.type() || reference.size() != fast.size())
    std::abort();
  if (cv::norm(reference, fast, cv::NORM_INF) != 0) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const Bytes rest(data + 1, data + size);
  switch (data[0] % 3) {
    case 0:
      Check(rest);
      break;
    case 1:
      Check(WithRepairedCrcs(rest));
      break;
    default:
      Check(BuiltPng(rest.data(), rest.size()));
      break;
  }
  return 0;
}
