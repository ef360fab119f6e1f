// TUM trajectory files: "t tx ty tz qx qy qz qw", world_from_cam (camera-to-world), 8 columns.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/base/types.h"

namespace dygslam {

// A position beyond this (metres, on any axis) is no camera trajectory: 1e300 would overflow
// every error computed from it.
inline constexpr double kMaxTrajectoryCoordinate = 1e7;

// Throws InputError naming file and line (wrong column count, non-numeric, non-finite, a
// coordinate beyond kMaxTrajectoryCoordinate, unsorted or duplicate stamps, non-unit quaternion
// beyond tolerance).
std::vector<StampedPose> ReadTumTrajectory(const std::string& path);
// `path` reads as a TUM trajectory, whatever its coordinates (a file a run wrote with poses
// kilometres away is still that run's trajectory, to be replaced by the next run).
bool IsTumTrajectoryFile(const std::string& path);
// Writes atomically (temporary file + rename). Quaternions normalised, qw >= 0 not enforced.
void WriteTumTrajectory(const std::string& path, const std::vector<StampedPose>& poses);
// The text WriteTumTrajectory writes (`path` names the file in its errors).
std::string FormatTumTrajectory(const std::string& path, const std::vector<StampedPose>& poses);
// Pose at `stamp` by linear / slerp interpolation between the neighbouring samples of a
// trajectory sorted by stamp; nullopt outside it or where the neighbours are more than max_gap
// seconds apart.
std::optional<Rigid3d> InterpolatePose(const std::vector<StampedPose>& trajectory, Timestamp stamp,
                                       double max_gap = 0.1);

}  // namespace dygslam
