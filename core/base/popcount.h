// Hamming distance of 256-bit binary descriptors (ORB) with the CPU's POPCNT instruction when it
// has one. The build targets plain x86-64 (no -mpopcnt), where __builtin_popcountll is a call to
// libgcc's table-based __popcountdi2 (4 calls per distance); here one function compiled for the
// popcnt target is chosen at run time (__builtin_cpu_supports), so the binary stays portable.
// Both paths give the same counts.
#pragma once

#include <cstdint>

namespace dygslam {
namespace popcount_internal {

// Set once at start-up from the CPU's feature flags.
extern const bool kCpuHasPopcnt;
// Bit count of (a ^ b) over 4 words, with the popcnt instruction; call only if kCpuHasPopcnt.
int HammingDistance256Popcnt(const uint64_t* a, const uint64_t* b);

inline int HammingDistance256Generic(const uint64_t* a, const uint64_t* b) {
  return __builtin_popcountll(a[0] ^ b[0]) + __builtin_popcountll(a[1] ^ b[1]) +
         __builtin_popcountll(a[2] ^ b[2]) + __builtin_popcountll(a[3] ^ b[3]);
}

}  // namespace popcount_internal

// Number of differing bits of two 256-bit descriptors (4 words each).
inline int HammingDistance256Words(const uint64_t* a, const uint64_t* b) {
  return popcount_internal::kCpuHasPopcnt ? popcount_internal::HammingDistance256Popcnt(a, b)
                                          : popcount_internal::HammingDistance256Generic(a, b);
}

// Whether the hardware path is used on this CPU (for logs and tests).
inline bool HammingDistanceUsesPopcnt() { return popcount_internal::kCpuHasPopcnt; }

}  // namespace dygslam
