// The binary feature descriptor shared by feature extraction (core/slam) and place recognition
// (core/place), so that neither includes the other's headers.
#pragma once

#include <array>
#include <cstdint>

#include "core/base/popcount.h"

namespace dygslam {

// 256-bit binary descriptor (ORB's steered BRIEF).
using Descriptor = std::array<uint64_t, 4>;

// With the CPU's POPCNT instruction when it has one (core/base/popcount.h).
inline int HammingDistance(const Descriptor& a, const Descriptor& b) {
  return HammingDistance256Words(a.data(), b.data());
}

}  // namespace dygslam
