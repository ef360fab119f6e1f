#include "core/base/memory.h"

#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <vector>

namespace dygslam {
namespace {

TEST(Memory, ResidentBytesFollowsTouchedMemory) {
  const size_t before = ResidentBytes();
  ASSERT_GT(before, 0u);
  std::vector<char> block(64u << 20);
  std::memset(block.data(), 1, block.size());
  EXPECT_GE(ResidentBytes(), before + (48u << 20));
}

#ifdef __GLIBC__
// Small blocks freed below one that stays allocated: glibc cannot shrink the heap from the top and
// keeps the pages resident; ReleaseFreedMemory gives them back.
TEST(Memory, ReleaseFreedMemoryReturnsPagesFreedInTheMiddleOfTheHeap) {
  constexpr size_t kBlocks = 80000, kBlockSize = 1000;  // ~80 MB below the top
  std::vector<std::unique_ptr<char[]>> blocks;
  blocks.reserve(kBlocks);
  for (size_t i = 0; i < kBlocks; ++i) {
    blocks.emplace_back(new char[kBlockSize]);
    std::memset(blocks.back().get(), 1, kBlockSize);
  }
  std::unique_ptr<char[]> pin(new char[kBlockSize]);  // above the freed ones
  std::memset(pin.get(), 1, kBlockSize);
  const size_t allocated = ResidentBytes();
  for (auto& b : blocks) b.reset();
  const size_t freed = ResidentBytes();
  ReleaseFreedMemory();
  const size_t trimmed = ResidentBytes();
  EXPECT_GT(freed, trimmed + (60u << 20))
      << "allocated " << (allocated >> 20) << " MB, after free " << (freed >> 20)
      << " MB, after trim " << (trimmed >> 20) << " MB";
}
#endif

}  // namespace
}  // namespace dygslam
