// Atomic file output for the mapping library: write a temporary file next to the target, then
// rename it over the target, so a reader never sees a half-written map or picture.
#pragma once

#include <string>

namespace dygslam {

// Writes `bytes` to `path` atomically. Throws InputError naming the file on failure.
void WriteFileAtomically(const std::string& path, const std::string& bytes);

}  // namespace dygslam
