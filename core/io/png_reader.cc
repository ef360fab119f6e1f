#include "core/io/png_reader.h"

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <vector>

#ifdef DYGSLAM_HAVE_LIBDEFLATE
#include <libdeflate.h>
#endif

namespace dygslam {
namespace {

[[maybe_unused]] uint32_t BigEndian32(const unsigned char* p) {
  return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | uint32_t(p[3]);
}

// Ancillary chunks that cv::imread(IMREAD_UNCHANGED) ignores; any other chunk (tRNS, gAMA, sBIT,
// PLTE, iCCP, ...) may change what OpenCV returns: such files go to OpenCV.
[[maybe_unused]] bool IsIgnoredAncillary(const unsigned char* type) {
  static const char* kIgnored[] = {"tEXt", "zTXt", "iTXt", "tIME", "pHYs"};
  for (const char* t : kIgnored)
    if (std::memcmp(type, t, 4) == 0) return true;
  return false;
}

// Paeth: each byte predicted by the neighbour (left a, up b, upper-left c) closest to a + b - c,
// ties in the order a, b, c. Any bytes per pixel; UnfilterPaethFixed is the fast path.
[[maybe_unused]] void UnfilterPaethScalar(unsigned char* cur, const unsigned char* prev,
                                          size_t begin, size_t row_bytes, int bpp) {
  for (size_t i = begin; i < row_bytes; ++i) {
    const int a = i >= size_t(bpp) ? cur[i - bpp] : 0, b = prev[i];
    const int c = i >= size_t(bpp) ? prev[i - bpp] : 0;
    const int pa = std::abs(b - c), pb = std::abs(a - c), pc = std::abs(a + b - 2 * c);
    const int predictor = (pa <= pb && pa <= pc) ? a : (pb <= pc ? b : c);
    cur[i] = uint8_t(cur[i] + predictor);
  }
}

// Paeth for `Bpp` bytes per pixel: the left and upper-left neighbours of each channel stay in
// registers from one pixel to the next (no load of the byte just stored); the choice is
// branch-free.
template <int Bpp>
void UnfilterPaethFixed(unsigned char* cur, const unsigned char* prev, size_t row_bytes) {
  int a[Bpp], c[Bpp];
  for (int k = 0; k < Bpp; ++k) {  // first pixel: a = c = 0, the predictor is b
    cur[k] = uint8_t(cur[k] + prev[k]);
    a[k] = cur[k];
    c[k] = prev[k];
  }
  for (size_t i = Bpp; i + Bpp <= row_bytes; i += Bpp) {
    for (int k = 0; k < Bpp; ++k) {
      const int b = prev[i + k];
      const int pa = std::abs(b - c[k]), pb = std::abs(a[k] - c[k]);
      const int pc = std::abs(a[k] + b - 2 * c[k]);
      const int bc = pb <= pc ? b : c[k];
      const int predictor = (pa <= pb && pa <= pc) ? a[k] : bc;
      a[k] = uint8_t(cur[i + k] + predictor);
      cur[i + k] = uint8_t(a[k]);
      c[k] = b;
    }
  }
}

[[maybe_unused]] void UnfilterPaeth(unsigned char* cur, const unsigned char* prev, size_t row_bytes,
                                    int bpp) {
  if (row_bytes % size_t(bpp) == 0) {
    switch (bpp) {
      case 1:
        return UnfilterPaethFixed<1>(cur, prev, row_bytes);
      case 2:
        return UnfilterPaethFixed<2>(cur, prev, row_bytes);
      case 3:
        return UnfilterPaethFixed<3>(cur, prev, row_bytes);
      case 4:
        return UnfilterPaethFixed<4>(cur, prev, row_bytes);
      default:
        break;
    }
  }
  UnfilterPaethScalar(cur, prev, 0, row_bytes, bpp);
}

// Reverses the PNG row filters in place (rows of 1 + row_bytes: the filter type, then the
// bytes). False for an unknown filter type.
[[maybe_unused]] bool Unfilter(unsigned char* data, int rows, size_t row_bytes, int bpp) {
  const std::vector<unsigned char> zeros(row_bytes, 0);
  const unsigned char* prev = zeros.data();
  for (int y = 0; y < rows; ++y) {
    unsigned char* row = data + y * (row_bytes + 1);
    const unsigned char filter = row[0];
    unsigned char* cur = row + 1;
    switch (filter) {
      case 0:
        break;
      case 1:
        for (size_t i = bpp; i < row_bytes; ++i) cur[i] = uint8_t(cur[i] + cur[i - bpp]);
        break;
      case 2:
        for (size_t i = 0; i < row_bytes; ++i) cur[i] = uint8_t(cur[i] + prev[i]);
        break;
      case 3:
        for (int i = 0; i < bpp; ++i) cur[i] = uint8_t(cur[i] + (prev[i] >> 1));
        for (size_t i = bpp; i < row_bytes; ++i)
          cur[i] = uint8_t(cur[i] + ((int(cur[i - bpp]) + int(prev[i])) >> 1));
        break;
      case 4:
        UnfilterPaeth(cur, prev, row_bytes, bpp);
        break;
      default:
        return false;
    }
    prev = cur;
  }
  return true;
}

}  // namespace

#ifdef DYGSLAM_HAVE_LIBDEFLATE

bool FastPngAvailable() { return true; }

namespace {

// The fields of a PNG's IHDR and its IDAT data (concatenated).
struct PngChunks {
  uint32_t width = 0, height = 0;
  int bit_depth = 0, color_type = -1;
  std::vector<unsigned char> compressed;
};

// The chunks of a PNG file, each CRC-checked; false for anything this decoder does not take
// (interlaced, unknown critical chunks, no IEND).
bool ReadChunks(const unsigned char* data, size_t size, PngChunks* png) {
  static const unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (size < 8 + 25 || std::memcmp(data, kSignature, 8) != 0) return false;
  size_t pos = 8;
  bool seen_header = false, seen_end = false;
  while (pos + 12 <= size && !seen_end) {
    const uint32_t length = BigEndian32(data + pos);
    const unsigned char* type = data + pos + 4;
    if (length > size - pos - 12) return false;
    const unsigned char* body = data + pos + 8;
    const uint32_t crc = BigEndian32(body + length);
    if (libdeflate_crc32(0, type, length + 4) != crc) return false;
    if (!seen_header) {
      if (std::memcmp(type, "IHDR", 4) != 0 || length != 13) return false;
      png->width = BigEndian32(body);
      png->height = BigEndian32(body + 4);
      png->bit_depth = body[8];
      png->color_type = body[9];
      // compression 0, filter method 0, not interlaced
      if (body[10] != 0 || body[11] != 0 || body[12] != 0) return false;
      seen_header = true;
    } else if (std::memcmp(type, "IDAT", 4) == 0) {
      png->compressed.insert(png->compressed.end(), body, body + length);
    } else if (std::memcmp(type, "IEND", 4) == 0) {
      seen_end = true;
    } else if (!IsIgnoredAncillary(type)) {
      return false;
    }
    pos += 12 + size_t(length);
  }
  return seen_end && !png->compressed.empty();
}

// The unfiltered rows (each after its filter byte) into `out`, as OpenCV gives them: RGB(A) as
// BGR(A), 16-bit samples in host order.
void CopyRows(const std::vector<unsigned char>& raw, size_t row_bytes, int channels, int bit_depth,
              cv::Mat* out) {
  const int width = out->cols;
  for (int y = 0; y < out->rows; ++y) {
    const unsigned char* src = raw.data() + y * (row_bytes + 1) + 1;
    unsigned char* dst = out->ptr<unsigned char>(y);
    if (channels == 3 || channels == 4) {
      for (int x = 0; x < width; ++x, src += channels, dst += channels) {
        dst[0] = src[2];
        dst[1] = src[1];
        dst[2] = src[0];
        if (channels == 4) dst[3] = src[3];
      }
    } else if (bit_depth == 16) {
      uint16_t* d16 = reinterpret_cast<uint16_t*>(dst);
      for (int x = 0; x < width; ++x) d16[x] = uint16_t((src[2 * x] << 8) | src[2 * x + 1]);
    } else {
      std::memcpy(dst, src, row_bytes);
    }
  }
}

}  // namespace

bool DecodePngFast(const unsigned char* data, size_t size, cv::Mat* image) {
  thread_local PngChunks png;  // its IDAT buffer is kept from one image to the next
  png.compressed.clear();
  if (!ReadChunks(data, size, &png)) return false;
  const uint32_t width = png.width, height = png.height;
  if (width == 0 || height == 0 || width > 16384 || height > 16384) return false;
  const int bit_depth = png.bit_depth, color_type = png.color_type;
  int channels = 0, cv_type = -1;
  if (bit_depth == 8 && color_type == 0) channels = 1, cv_type = CV_8UC1;
  if (bit_depth == 8 && color_type == 2) channels = 3, cv_type = CV_8UC3;
  if (bit_depth == 8 && color_type == 6) channels = 4, cv_type = CV_8UC4;
  if (bit_depth == 16 && color_type == 0) channels = 1, cv_type = CV_16UC1;
  if (cv_type < 0) return false;
  const int bpp = channels * bit_depth / 8;
  const size_t row_bytes = size_t(width) * bpp;
  const size_t raw_size = size_t(height) * (row_bytes + 1);
  // Deflate expands at most 1032:1 (258 bytes from a 1-bit length and a 1-bit distance code):
  // a header asking for more than the IDAT data could fill is refused before allocating (a
  // 100-byte file claiming 16384x16384 RGBA would cost 1 GB here; OpenCV then reports it).
  if (raw_size / 1032 > png.compressed.size() + 1024) return false;
  // The inflated rows in a buffer kept by the thread: a fresh 1 MB buffer per image cost more in
  // page faults and zero-filling than the unfiltering itself.
  thread_local std::vector<unsigned char> raw;
  if (raw.size() > (size_t(64) << 20) && raw.size() > 4 * raw_size) raw = {};  // one huge image
  if (raw.size() < raw_size) raw.resize(raw_size);

  struct DecompressorDeleter {
    void operator()(libdeflate_decompressor* d) const { libdeflate_free_decompressor(d); }
  };
  thread_local std::unique_ptr<libdeflate_decompressor, DecompressorDeleter> decompressor(
      libdeflate_alloc_decompressor());
  if (!decompressor) return false;
  // The stream must fill the image exactly (NULL actual size: a shorter one is an error).
  if (libdeflate_zlib_decompress(decompressor.get(), png.compressed.data(), png.compressed.size(),
                                 raw.data(), raw_size, nullptr) != LIBDEFLATE_SUCCESS)
    return false;
  if (!Unfilter(raw.data(), int(height), row_bytes, bpp)) return false;

  cv::Mat out(int(height), int(width), cv_type);
  CopyRows(raw, row_bytes, channels, bit_depth, &out);
  *image = out;
  return true;
}

#else

bool FastPngAvailable() { return false; }
bool DecodePngFast(const unsigned char*, size_t, cv::Mat*) { return false; }

#endif

bool ReadPngFast(const std::string& path, cv::Mat* image) {
  if (!FastPngAvailable()) return false;
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size <= 0 || size > (std::streamoff(1) << 30)) return false;
  in.seekg(0, std::ios::beg);
  std::vector<unsigned char> bytes(static_cast<size_t>(size));
  if (!in.read(reinterpret_cast<char*>(bytes.data()), size)) return false;
  return DecodePngFast(bytes.data(), bytes.size(), image);
}

}  // namespace dygslam
