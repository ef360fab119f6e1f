// libFuzzer target: TUM trajectory files through ReadTumTrajectory. Contract: InputError, or
// poses that are finite, unit-quaternion and strictly increasing in time, which
// WriteTumTrajectory writes and ReadTumTrajectory reads back identically in count and stamps.
#include <cstdlib>

#include "core/base/error.h"
#include "core/io/trajectory_io.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace dygslam;
  const std::string path = fuzz::ScratchDir() + "/trajectory.txt";
  const std::string copy = fuzz::ScratchDir() + "/trajectory_copy.txt";
  fuzz::WriteFile(path, std::string_view(reinterpret_cast<const char*>(data), size));
  std::vector<StampedPose> poses;
  try {
    poses = ReadTumTrajectory(path);
  } catch (const InputError&) {
    return 0;
  }
  for (size_t i = 0; i < poses.size(); ++i) {
    if (!poses[i].world_from_cam.AllFinite()) std::abort();
    if (std::abs(poses[i].world_from_cam.rotation.norm() - 1.0) > 1e-6) std::abort();
    if (i > 0 && !(poses[i - 1].stamp < poses[i].stamp)) std::abort();
  }
  WriteTumTrajectory(copy, poses);
  const std::vector<StampedPose> again = ReadTumTrajectory(copy);
  if (again.size() != poses.size()) std::abort();
  for (size_t i = 0; i < poses.size(); ++i) {
    if (again[i].stamp != poses[i].stamp) std::abort();
  }
  return 0;
}
