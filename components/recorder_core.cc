#include "components/recorder_core.h"

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <utility>

#include "components/convert.h"
#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/base/log.h"
#include "core/io/file_util.h"
#include "core/io/trajectory_io.h"

namespace dygslam {

namespace {

// The first line of OUTPUT/groundtruth.txt as the recorder writes it.
constexpr char kGroundTruthCopyLine[] =
    "# ground truth of the played frames, a copy written by the dygslam recorder\n";

std::string ReadWhole(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

}  // namespace

void RecorderOptions::Check() const {
  DYGSLAM_CHECK_OPTION(!output_dir.empty(), "recorder.output_dir");
  DYGSLAM_CHECK_OPTION(flush_timeout_s >= 0, "recorder.flush_timeout_s");
}

RecorderCore::RecorderCore(const RecorderOptions& options) : options_(options) {
  options_.Check();
  std::error_code ec;
  // A copy an earlier recorder wrote (its first line says so) is replaced like the other outputs;
  // any other file of that name (a user's ground truth) is kept.
  const std::filesystem::path copy = std::filesystem::path(options_.output_dir) / "groundtruth.txt";
  const auto status = std::filesystem::symlink_status(copy, ec);
  ground_truth_file_existed_ =
      std::filesystem::exists(status) && !(std::filesystem::is_regular_file(status) &&
                                           ReadWhole(copy).rfind(kGroundTruthCopyLine, 0) == 0);
}

FrameRow FrameRowFromPose(const msg::CameraPose& m) {
  FrameRow row;
  row.stamp = TimeFromMsg(m.header().stamp(), "CameraPose.header.stamp");
  if (m.tracking_state() > static_cast<uint8_t>(TrackingState::kFallback)) {
    throw InputError("CameraPose.tracking_state: " + std::to_string(m.tracking_state()) +
                     " is not a tracking state (0..4)");
  }
  row.state = static_cast<TrackingState>(m.tracking_state());
  row.is_keyframe = m.is_keyframe();
  row.num_features = m.num_features();
  row.num_dynamic = m.num_dynamic();
  row.num_tracked = m.num_tracked();
  row.times.orb_extraction_ms = m.orb_extraction_ms();
  row.times.detection_ms = m.detection_ms();
  row.times.matching_ms = m.matching_ms();
  row.times.probability_ms = m.probability_ms();
  row.times.tracking_ms = m.tracking_ms();
  row.times.total_ms = m.total_ms();
  return row;
}

void RecorderCore::AddPose(const msg::CameraPose& pose) {
  const Timestamp stamp = TimeFromMsg(pose.header().stamp(), "CameraPose.header.stamp");
  FrameRow row = FrameRowFromPose(pose);
  if (pose.has_pose()) {
    StampedPose p;
    p.stamp = stamp;
    p.world_from_cam = PoseFromMsg(pose.world_from_cam(), "CameraPose.world_from_cam");
    online_.push_back(p);
    if (pose.is_keyframe()) online_keyframes_.push_back(p);
  }
  if (pose.tracking_state() == static_cast<uint8_t>(TrackingState::kLost)) ++num_lost_;
  frame_rows_.push_back(row);
}

void RecorderCore::SetTrajectory(const msg::Trajectory& trajectory) {
  std::vector<StampedPose> poses = TrajectoryFromMsg(trajectory);
  if (trajectory.keyframes_only()) {
    final_keyframes_ = std::move(poses);
  } else {
    final_frames_ = std::move(poses);
  }
}

void RecorderCore::AddGroundTruth(const msg::GroundTruthPose& pose) {
  ground_truth_.push_back(GroundTruthFromMsg(pose));
}

namespace {

std::vector<StampedPose> SortedUnique(std::vector<StampedPose> poses) {
  std::stable_sort(poses.begin(), poses.end(),
                   [](const StampedPose& a, const StampedPose& b) { return a.stamp < b.stamp; });
  poses.erase(
      std::unique(poses.begin(), poses.end(),
                  [](const StampedPose& a, const StampedPose& b) { return a.stamp == b.stamp; }),
      poses.end());
  return poses;
}

}  // namespace

void RecorderCore::WriteGroundTruthCopy(const std::filesystem::path& path) const {
  const std::string plain = FormatTumTrajectory(path.string(), SortedUnique(ground_truth_));
  if (!ground_truth_file_existed_) {
    WriteFileAtomically(path.string(), kGroundTruthCopyLine + plain);
    return;
  }
  // A file this recorder did not write (a user's): kept; said unless it already holds exactly
  // this ground truth.
  std::error_code ec;
  const bool same = std::filesystem::is_regular_file(path, ec) && ReadWhole(path) == plain;
  if (!same) {
    LOG_WARNING << "recorder: " << EchoValue(path.string())
                << " was there before this run and is no ground truth copy a recorder wrote: left "
                   "as it was, the ground truth of the player is not copied";
  }
}

std::string RecorderCore::Write() const {
  {
    // Made again when removed while the run went; when something else took its place, the first
    // write names the file and what is in the folder's place.
    std::error_code ignored;
    std::filesystem::create_directories(options_.output_dir, ignored);
  }
  const std::filesystem::path dir(options_.output_dir);
  RunOutputs outputs(dir,
                     {"trajectory.txt", "trajectory_online.txt", "keyframes.txt", "frames.csv"});
  RunRecord record;
  record.rows = frame_rows_;
  std::stable_sort(record.rows->begin(), record.rows->end(),
                   [](const FrameRow& a, const FrameRow& b) { return a.stamp < b.stamp; });
  record.online = SortedUnique(online_);
  record.trajectory = final_frames_ ? *final_frames_ : *record.online;
  record.keyframes = final_keyframes_ ? *final_keyframes_ : SortedUnique(online_keyframes_);
  const bool written = WriteRunRecord(outputs, record);
  if (!ground_truth_.empty()) WriteGroundTruthCopy(dir / "groundtruth.txt");
  outputs.ThrowIfAnyFailed();  // every other file is written first
  if (!written) {
    LOG_INFO << "recorder: no frame received; the earlier trajectory.txt, keyframes.txt and "
                "frames.csv are left as they were";
    return "";
  }
  if (!record.HasFrames()) {
    LOG_INFO << "recorder: no frame received; empty trajectory.txt, keyframes.txt and frames.csv "
                "written";
  }
  return outputs.PathOf("trajectory.txt");
}

}  // namespace dygslam
