// The hardware and generic Hamming distances agree on random and edge-case descriptors.
#include "core/base/popcount.h"

#include <gtest/gtest.h>

#include <bitset>
#include <fstream>
#include <random>
#include <string>

namespace dygslam {
namespace {

int CountBits(const uint64_t* a, const uint64_t* b) {
  int n = 0;
  for (int k = 0; k < 4; ++k) n += static_cast<int>(std::bitset<64>(a[k] ^ b[k]).count());
  return n;
}

TEST(Popcount, HardwareAndGenericPathsGiveTheBitCount) {
  std::mt19937_64 rng(7);
  const uint64_t zero[4] = {0, 0, 0, 0}, ones[4] = {~0ull, ~0ull, ~0ull, ~0ull};
  EXPECT_EQ(HammingDistance256Words(zero, ones), 256);
  EXPECT_EQ(HammingDistance256Words(ones, ones), 0);
  for (int i = 0; i < 10000; ++i) {
    uint64_t a[4], b[4];
    for (int k = 0; k < 4; ++k) {
      a[k] = rng();
      b[k] = i % 3 == 0 ? a[k] ^ (1ull << (rng() % 64)) : rng();
    }
    const int expected = CountBits(a, b);
    ASSERT_EQ(popcount_internal::HammingDistance256Generic(a, b), expected);
    ASSERT_EQ(HammingDistance256Words(a, b), expected);
    if (HammingDistanceUsesPopcnt())
      ASSERT_EQ(popcount_internal::HammingDistance256Popcnt(a, b), expected);
  }
}

#if defined(__x86_64__) && defined(__linux__)
TEST(Popcount, HardwarePathChosenExactlyWhenTheCpuHasPopcnt) {
  std::ifstream cpuinfo("/proc/cpuinfo");
  ASSERT_TRUE(cpuinfo.good());
  std::string line;
  bool has = false;
  while (std::getline(cpuinfo, line)) {
    if (line.rfind("flags", 0) != 0) continue;
    has = (" " + line + " ").find(" popcnt ") != std::string::npos;
    break;
  }
  EXPECT_EQ(HammingDistanceUsesPopcnt(), has);
}
#endif

}  // namespace
}  // namespace dygslam
