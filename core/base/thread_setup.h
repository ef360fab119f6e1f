// What a thread says about itself to the operating system.
#pragma once

#include <string>

namespace dygslam {

// Names the calling thread, so that `top -H`, `ps -L` and debuggers show which stage of the
// pipeline uses the CPU (Linux keeps at most 15 characters; longer names are cut).
void SetCurrentThreadName(const std::string& name);
// The calling thread's name ("" where the platform does not keep one).
std::string CurrentThreadName();

// Gives the calling thread a lower CPU priority than the rest of the process (Linux: nice +10
// for this thread only). For work that has no deadline, such as building the map, so that on a
// busy machine it takes the CPU time tracking leaves over instead of delaying frames. Needs no
// privilege; returns false when the system refused.
bool LowerCurrentThreadPriority();
// The calling thread's nice value (0 where the platform has none).
int CurrentThreadNiceness();

}  // namespace dygslam
