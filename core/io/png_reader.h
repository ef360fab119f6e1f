// Fast PNG decoding for the dataset player (decoding through OpenCV was ~14 ms of CPU per frame, a
// quarter of a dataset run). The common dataset layouts (8-bit grey / RGB / RGBA, 16-bit grey,
// not interlaced, no palette or colour-management chunks) are decoded with libdeflate (the zlib
// stream) and an own unfiltering pass, into exactly what cv::imread(path, IMREAD_UNCHANGED) gives
// (BGR / BGRA channel order, 16-bit values in host order). Everything else returns false and the
// caller decodes with OpenCV (so errors and exotic files behave as before).
#pragma once

#include <opencv2/core.hpp>
#include <string>

namespace dygslam {

// True: the decoder is compiled in (libdeflate found at build time).
bool FastPngAvailable();

// Decodes the PNG file at `path` into *image (CV_8UC1/3/4 or CV_16UC1). False (image untouched):
// unreadable file, a layout this decoder does not handle, a CRC or zlib checksum mismatch, or
// any other inconsistency: decode with cv::imread instead, which reports the problem.
bool ReadPngFast(const std::string& path, cv::Mat* image);

// The same from the file's bytes.
bool DecodePngFast(const unsigned char* data, size_t size, cv::Mat* image);

}  // namespace dygslam
