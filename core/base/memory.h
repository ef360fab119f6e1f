#pragma once

#include <cstddef>

namespace dygslam {

// Hands freed heap pages back to the operating system (glibc: malloc_trim). glibc keeps freed
// pages of its arenas resident unless they are at the top of a heap; a long run that frees
// keyframes and optimisation problems in the middle of the heap then sees its resident set grow
// while the heap in use stays flat. Costs a walk over the free lists (about a millisecond for
// tens of MB); call it after large frees, not per frame. No-op without glibc.
void ReleaseFreedMemory();

// Resident set size of this process in bytes (/proc/self/statm), 0 when unknown.
size_t ResidentBytes();

}  // namespace dygslam
