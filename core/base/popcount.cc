#include "core/base/popcount.h"

namespace dygslam {
namespace popcount_internal {
namespace {

bool DetectPopcnt() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();  // needed before __builtin_cpu_supports in a static initialiser
  return __builtin_cpu_supports("popcnt");
#else
  return false;  // other architectures: the generic builtin (already a native instruction on most)
#endif
}

}  // namespace

const bool kCpuHasPopcnt = DetectPopcnt();

#if defined(__x86_64__) || defined(__i386__)
__attribute__((target("popcnt"))) int HammingDistance256Popcnt(const uint64_t* a,
                                                               const uint64_t* b) {
  return __builtin_popcountll(a[0] ^ b[0]) + __builtin_popcountll(a[1] ^ b[1]) +
         __builtin_popcountll(a[2] ^ b[2]) + __builtin_popcountll(a[3] ^ b[3]);
}
#else
int HammingDistance256Popcnt(const uint64_t* a, const uint64_t* b) {
  return HammingDistance256Generic(a, b);
}
#endif

}  // namespace popcount_internal
}  // namespace dygslam
