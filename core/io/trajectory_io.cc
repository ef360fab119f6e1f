#include "core/io/trajectory_io.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "core/base/error.h"
#include "core/io/file_util.h"

namespace dygslam {
namespace {

constexpr double kQuaternionNormTolerance = 1e-2;

double ParseValue(const std::string& file, int line, int column, const std::string& text) {
  const char* begin = text.c_str();
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(begin, &end);
  // Decimal only: strtod also reads hexadecimal ("0x10" is 16), which no trajectory writes.
  const bool hexadecimal = text.find_first_of("xX") != std::string::npos;
  if (end == begin || *end != '\0' || hexadecimal) {
    throw InputError(
        file, line,
        "column " + std::to_string(column) + ": not a number: '" + Abbreviate(text) + "'");
  }
  // strtod gives +-HUGE_VAL with ERANGE for a number beyond a double ("1e400"), and a tiny or zero
  // value with ERANGE for one too close to zero ("1e-400"): that one reads as what it rounds to.
  const bool overflow = errno == ERANGE && std::abs(v) == HUGE_VAL;
  if (!std::isfinite(v) || overflow) {
    throw InputError(
        file, line,
        "column " + std::to_string(column) + ": " +
            (overflow ? "value out of range (beyond a double) '" : "non-finite value '") +
            Abbreviate(text) + "'");
  }
  return v;
}

}  // namespace

namespace {

std::vector<StampedPose> ReadTum(const std::string& path, bool plausible_coordinates) {
  std::vector<StampedPose> poses;
  for (const TextLine& l : ReadDataLines(path)) {
    if (l.tokens.size() != 8) {
      throw InputError(
          path, l.line_number,
          "expected 8 columns 't tx ty tz qx qy qz qw', found " + std::to_string(l.tokens.size()));
    }
    const std::optional<Timestamp> stamp = Timestamp::Parse(l.tokens[0]);
    if (!stamp)
      throw InputError(path, l.line_number,
                       "malformed timestamp '" + Abbreviate(l.tokens[0]) + "'");
    double v[7];
    for (int c = 0; c < 7; ++c) v[c] = ParseValue(path, l.line_number, c + 2, l.tokens[c + 1]);
    for (int c = 0; c < 3 && plausible_coordinates; ++c) {
      if (std::abs(v[c]) > kMaxTrajectoryCoordinate) {
        char why[160];
        std::snprintf(why, sizeof(why),
                      "column %d: coordinate %g m is beyond %g m (not a camera trajectory)", c + 2,
                      v[c], kMaxTrajectoryCoordinate);
        throw InputError(path, l.line_number, why);
      }
    }
    const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);  // (w, x, y, z)
    const double norm = q.norm();
    if (std::abs(norm - 1.0) > kQuaternionNormTolerance) {
      char buffer[64];
      std::snprintf(buffer, sizeof(buffer), "%.6g", norm);
      throw InputError(path, l.line_number,
                       std::string("quaternion is not unit length (norm ") + buffer + ")");
    }
    if (!poses.empty()) {
      if (*stamp == poses.back().stamp) {
        throw InputError(path, l.line_number, "duplicate timestamp " + stamp->ToString());
      }
      if (*stamp < poses.back().stamp) {
        throw InputError(path, l.line_number,
                         "timestamps not sorted: " + stamp->ToString() + " after " +
                             poses.back().stamp.ToString());
      }
    }
    StampedPose pose;
    pose.stamp = *stamp;
    pose.world_from_cam = Rigid3d(q.normalized(), Eigen::Vector3d(v[0], v[1], v[2]));
    poses.push_back(pose);
  }
  return poses;
}

}  // namespace

std::vector<StampedPose> ReadTumTrajectory(const std::string& path) {
  return ReadTum(path, /*plausible_coordinates=*/true);
}

bool IsTumTrajectoryFile(const std::string& path) {
  try {
    ReadTum(path, /*plausible_coordinates=*/false);
    return true;
  } catch (const InputError&) {
    return false;
  }
}

void WriteTumTrajectory(const std::string& path, const std::vector<StampedPose>& poses) {
  WriteFileAtomically(path, FormatTumTrajectory(path, poses));
}

std::string FormatTumTrajectory(const std::string& path, const std::vector<StampedPose>& poses) {
  std::string out = "# timestamp tx ty tz qx qy qz qw (world_from_cam)\n";
  char buffer[512];
  for (size_t i = 0; i < poses.size(); ++i) {
    const StampedPose& p = poses[i];
    if (!p.world_from_cam.AllFinite()) {
      throw InputError(path, 0,
                       "pose " + std::to_string(i) + " at " + p.stamp.ToString() +
                           " is not finite; refusing to write");
    }
    if (i > 0 && p.stamp <= poses[i - 1].stamp) {
      throw InputError(path, 0, "poses not strictly sorted by timestamp at " + p.stamp.ToString());
    }
    const Eigen::Quaterniond q = p.world_from_cam.rotation.normalized();
    const Eigen::Vector3d& t = p.world_from_cam.translation;
    std::snprintf(buffer, sizeof(buffer), "%s %.12g %.12g %.12g %.12g %.12g %.12g %.12g\n",
                  p.stamp.ToString().c_str(), t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
    out += buffer;
  }
  return out;
}

std::optional<Rigid3d> InterpolatePose(const std::vector<StampedPose>& trajectory, Timestamp stamp,
                                       double max_gap) {
  auto after = std::lower_bound(trajectory.begin(), trajectory.end(), stamp,
                                [](const StampedPose& p, Timestamp t) { return p.stamp < t; });
  if (after == trajectory.end()) return std::nullopt;
  if (after->stamp == stamp) return after->world_from_cam;
  if (after == trajectory.begin()) return std::nullopt;
  const auto before = after - 1;
  const double gap = SecondsBetween(before->stamp, after->stamp);
  if (gap > max_gap) return std::nullopt;
  const double s = SecondsBetween(before->stamp, stamp) / gap;
  const Rigid3d& a = before->world_from_cam;
  const Rigid3d& b = after->world_from_cam;
  return Rigid3d(a.rotation.slerp(s, b.rotation), (1 - s) * a.translation + s * b.translation);
}

}  // namespace dygslam
