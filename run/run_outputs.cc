#include "run/run_outputs.h"

#include <octomap/OcTree.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <stdexcept>

#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/io/file_util.h"
#include "core/io/trajectory_io.h"
#include "core/place/vocabulary.h"
#include "core/slam/feature/orb_extractor.h"
#include "core/slam/map/frame.h"
#include "core/slam/map/map.h"
#include "core/slam/map/map_file.h"
#include "mapping/keyframe_mapper.h"
#include "run/realtime_report.h"

namespace dygslam {
namespace fs = std::filesystem;

namespace {

// The folder a file goes into (device and inode only: its times change with every file written).
FileVersion FolderOf(const fs::path& file) {
  const fs::path parent = file.parent_path();
  const FileVersion v = FileVersionOf(parent.empty() ? std::string(".") : parent.string());
  FileVersion folder;
  folder.exists = v.exists;
  folder.device = v.device;
  folder.inode = v.inode;
  return folder;
}

}  // namespace

RunOutputs::RunOutputs(std::filesystem::path directory, std::vector<std::string> names)
    : directory_(std::move(directory)) {
  // The file-system clock's now, as file times read (FileVersion::mtime_ns), a second early:
  // file times are taken from a coarser clock than the one read here.
  started_ns_ = std::chrono::duration_cast<std::chrono::nanoseconds>(
                    std::chrono::system_clock::now().time_since_epoch())
                    .count() -
                1000000000LL;
  for (const std::string& name : names) {
    names_.push_back(name);
    before_[name] = FileVersionOf((directory_ / name).string());
    folder_before_[name] = FolderOf(directory_ / name);
  }
}

void RunOutputs::AddFile(const std::string& path) {
  if (paths_.count(path) != 0) return;
  names_.push_back(path);
  paths_[path] = path;
  before_[path] = FileVersionOf(path);
  folder_before_[path] = FolderOf(path);
}

std::string RunOutputs::PathOf(const std::string& name) const {
  const auto it = paths_.find(name);
  // The folder where it is now (PinOutputFolder: replaced while the run went, the outputs went
  // into the folder the run started with).
  return it != paths_.end()
             ? it->second
             : (std::filesystem::path(PinnedFolderNow(directory_.string())) / name).string();
}

bool RunOutputs::Write(const std::string& name, const std::function<void()>& write) {
  try {
    write();
    return true;
  } catch (const std::exception& e) {
    RecordFailure(name, e.what());
    return false;
  }
}

void RunOutputs::RecordFailure(const std::string& name, const std::string& reason) {
  failures_.emplace_back(name, reason);
}

bool RunOutputs::Fresh(const std::string& name) const {
  const FileVersion now = FileVersionOf(PathOf(name));
  const auto it = before_.find(name);
  if (!now.exists || (it != before_.end() && it->second == now)) return false;
  if (InItsFolder(name)) return true;
  // Another folder under the name now: made again after the first was removed (by this command
  // or another process of the run), its files are this run's when written since it started; a
  // link put in its place names somebody else's folder.
  std::error_code ec;
  const fs::path parent = fs::path(PathOf(name)).parent_path();
  if (fs::is_symlink(parent.empty() ? fs::path(".") : parent, ec)) return false;
  return now.mtime_ns >= started_ns_;
}

bool RunOutputs::Stale(const std::string& name) const {
  return !Fresh(name) && InItsFolder(name) && FileVersionOf(PathOf(name)).exists;
}

bool RunOutputs::InItsFolder(const std::string& name) const {
  const auto folder = folder_before_.find(name);
  return folder == folder_before_.end() || !folder->second.exists ||
         FolderOf(PathOf(name)) == folder->second;
}

std::vector<std::string> RunOutputs::FreshNames() const {
  std::vector<std::string> out;
  for (const std::string& name : names_)
    if (Fresh(name)) out.push_back(name);
  return out;
}

std::vector<std::string> RunOutputs::StaleNames() const {
  std::vector<std::string> out;
  for (const std::string& name : names_)
    if (Stale(name)) out.push_back(name);
  return out;
}

void RunOutputs::ThrowIfAnyFailed() const {
  if (failures_.empty()) return;
  const auto& [name, reason] = failures_.front();
  throw std::runtime_error(name + " not written: " + reason);
}

std::string RunOutputs::FailureReport(const std::string& command) const {
  std::string text;
  for (const auto& [name, reason] : failures_)
    text += "dygslam " + command + ": error: " + name + " not written: " + reason + "\n";
  return text;
}

FrameRow FrameRowFromResult(const FrameResult& result) {
  FrameRow row;
  row.stamp = result.stamp;
  row.state = result.state;
  row.is_keyframe = result.is_keyframe;
  row.num_features = result.num_features;
  row.num_dynamic = result.num_dynamic;
  row.num_tracked = result.num_tracked;
  row.times = result.times;
  return row;
}

namespace {

// The stage columns of frames.csv after the frame's counts, in order, with their field.
const std::vector<std::pair<const char*, double StageTimes::*>>& StageColumns() {
  static const std::vector<std::pair<const char*, double StageTimes::*>> kColumns = {
      {"orb_ms", &StageTimes::orb_extraction_ms},
      {"detection_ms", &StageTimes::detection_ms},
      {"matching_ms", &StageTimes::matching_ms},
      {"probability_ms", &StageTimes::probability_ms},
      {"tracking_ms", &StageTimes::tracking_ms},
      {"total_ms", &StageTimes::total_ms},
      {"detection_wait_ms", &StageTimes::detection_wait_ms},
      {"local_mapping_ms", &StageTimes::local_mapping_ms},
      {"top_up_ms", &StageTimes::top_up_ms}};
  return kColumns;
}

}  // namespace

std::string FramesCsvHeader() {
  std::string header = "stamp,state,keyframe,features,dynamic,tracked";
  for (const auto& [name, field] : StageColumns()) header += std::string(",") + name;
  return header + "\n";
}

std::string FramesCsvRow(const FrameRow& r) {
  char line[512];
  std::snprintf(line, sizeof(line), "%s,%s,%d,%d,%d,%d", r.stamp.ToString().c_str(),
                ToString(r.state), r.is_keyframe ? 1 : 0, r.num_features, r.num_dynamic,
                r.num_tracked);
  std::string row = line;
  for (const auto& [name, field] : StageColumns()) {
    std::snprintf(line, sizeof(line), ",%.3f", r.times.*field);
    row += line;
  }
  return row + "\n";
}

std::vector<FrameRow> ReadFramesCsv(const std::string& path) {
  const std::vector<TextLine> lines = ReadDataLines(path);
  if (lines.empty() || lines.front().tokens.empty() || lines.front().tokens[0] != "stamp")
    throw InputError(path, lines.empty() ? 0 : lines.front().line_number,
                     "not a frames.csv: its first line is not the header 'stamp,state,...'");
  std::map<std::string, size_t> column;
  for (size_t i = 0; i < lines.front().tokens.size(); ++i) column[lines.front().tokens[i]] = i;
  if (column.count("state") == 0)
    throw InputError(path, lines.front().line_number, "no 'state' column");
  std::map<std::string, TrackingState> states;
  for (const TrackingState s :
       {TrackingState::kNotInitialized, TrackingState::kOk, TrackingState::kFallback,
        TrackingState::kRelocalized, TrackingState::kLost})
    states[ToString(s)] = s;
  auto number = [&](const TextLine& l, const std::string& name, double fallback) {
    const auto it = column.find(name);
    if (it == column.end()) return fallback;
    const std::string& text = l.tokens[it->second];
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || *end != '\0' || !std::isfinite(v))
      throw InputError(path, l.line_number, name + ": not a number: '" + EchoValue(text) + "'");
    return v;
  };
  std::vector<FrameRow> rows;
  for (size_t k = 1; k < lines.size(); ++k) {
    const TextLine& l = lines[k];
    if (l.tokens.size() != lines.front().tokens.size())
      throw InputError(path, l.line_number,
                       "expected " + std::to_string(lines.front().tokens.size()) +
                           " columns as the header, found " + std::to_string(l.tokens.size()));
    FrameRow r;
    const std::optional<Timestamp> stamp = Timestamp::Parse(l.tokens[0]);
    if (!stamp)
      throw InputError(path, l.line_number, "malformed stamp '" + EchoValue(l.tokens[0]) + "'");
    r.stamp = *stamp;
    const auto state = states.find(l.tokens[column["state"]]);
    if (state == states.end())
      throw InputError(path, l.line_number,
                       "unknown state '" + EchoValue(l.tokens[column["state"]]) + "'");
    r.state = state->second;
    r.is_keyframe = number(l, "keyframe", 0) != 0;
    r.num_features = static_cast<int>(number(l, "features", 0));
    r.num_dynamic = static_cast<int>(number(l, "dynamic", 0));
    r.num_tracked = static_cast<int>(number(l, "tracked", 0));
    for (const auto& [name, field] : StageColumns()) r.times.*field = number(l, name, 0);
    rows.push_back(r);
  }
  return rows;
}

bool RunRecord::HasFrames() const {
  return (rows && !rows->empty()) || !trajectory.empty() || (online && !online->empty());
}

RunRecord RunRecordOfSystem(const System& system) {
  RunRecord record;
  record.trajectory = system.Trajectory();
  record.keyframes = system.KeyframeTrajectory();
  return record;
}

bool WriteRunRecord(RunOutputs& outputs, const RunRecord& record) {
  std::error_code exists_error;
  if (!record.HasFrames() && fs::exists(outputs.PathOf("trajectory.txt"), exists_error))
    return false;
  if (record.rows) {
    outputs.Write("frames.csv", [&] {
      std::string csv = FramesCsvHeader();
      for (const FrameRow& row : *record.rows) csv += FramesCsvRow(row);
      WriteFileAtomically(outputs.PathOf("frames.csv"), csv);
    });
  }
  const auto trajectory = [&](const std::string& name, const std::vector<StampedPose>& poses) {
    outputs.Write(name, [&] { WriteTumTrajectory(outputs.PathOf(name), poses); });
  };
  trajectory("trajectory.txt", record.trajectory);
  if (record.keyframes) trajectory("keyframes.txt", *record.keyframes);
  if (record.online) trajectory("trajectory_online.txt", *record.online);
  return true;
}

void WriteMapperBinary(RunOutputs& outputs, KeyframeMapper& mapper, bool with_full_map) {
  mapper.Flush();
  mapper.WithBuilder([&](OctoMapBuilder& b) {
    // A continued map (--load-octomap) is written even when no keyframe was added to it.
    if (b.KeyframeIds().empty() && !b.has_base_map()) return;
    b.Finalize();
    // Each file a failure of its own (a full disk can take one and not the other).
    outputs.Write("map.bt", [&] { b.WriteBinary(outputs.PathOf("map.bt")); });
    if (with_full_map) outputs.Write("map.ot", [&] { b.WriteFull(outputs.PathOf("map.ot")); });
  });
}

size_t WriteMapFileOctoMap(const std::string& directory, const std::string& map_file,
                           const SystemOptions& options, const OctoMapOptions& octomap,
                           bool with_full_map) {
  octomap.Check();
  // The map as the System loads it: the same camera geometry, pyramid and vocabulary identity.
  const OrbExtractor extractor(options.orb);
  const auto geometry = std::make_shared<CameraGeometry>(
      CameraGeometry::Create(options.camera, options.sensor, extractor));
  uint64_t vocabulary_checksum = 0;
  if (!options.loop_closing.vocabulary.empty())
    vocabulary_checksum = Vocabulary::Load(options.loop_closing.vocabulary).Checksum();
  const LoadedMap loaded =
      LoadMapFile(map_file,
                  MapFileSettings::Of(*geometry, options.orb.scale_factor, vocabulary_checksum,
                                      options.sensor.depth_map_factor),
                  geometry);
  octomap::OcTree tree(octomap.resolution);
  tree.setProbHit(octomap.prob_hit);
  tree.setProbMiss(octomap.prob_miss);
  tree.setClampingThresMin(octomap.clamping_min);
  tree.setClampingThresMax(octomap.clamping_max);
  tree.setOccupancyThres(octomap.occupancy_threshold);
  size_t inserted = 0;
  // Keyframes in id order, each with the points it observes within range: one scan per keyframe.
  for (const auto& [id, keyframe] : loaded.map->keyframes()) {
    const Eigen::Vector3d centre = keyframe->CameraCenter();
    octomap::Pointcloud cloud;
    for (const auto& point : keyframe->map_points) {
      if (!point || point->bad) continue;
      const Eigen::Vector3d& p = point->position;
      const double range = (p - centre).norm();
      if (!p.allFinite() || range < octomap.min_range || range > octomap.max_range) continue;
      cloud.push_back(static_cast<float>(p.x()), static_cast<float>(p.y()),
                      static_cast<float>(p.z()));
    }
    if (cloud.size() == 0) continue;
    tree.insertPointCloud(
        cloud,
        octomap::point3d(static_cast<float>(centre.x()), static_cast<float>(centre.y()),
                         static_cast<float>(centre.z())),
        octomap.max_range, octomap.lazy_eval, /*discretize=*/false);
    inserted += cloud.size();
  }
  if (inserted == 0) return 0;
  tree.updateInnerOccupancy();
  WriteOctoMapBinary(tree, (fs::path(directory) / "map.bt").string());
  if (with_full_map) WriteOctoMapFull(tree, (fs::path(directory) / "map.ot").string());
  return inserted;
}

const std::vector<std::string>& RunOutputNames() {
  static const std::vector<std::string> names = {
      "trajectory.txt", "trajectory_online.txt", "keyframes.txt",     "frames.csv", "map.bt",
      "map.ot",         "groundtruth.txt",       kRealtimeReportFile, "eval.json"};
  return names;
}

void RecreateOutputDirIfRemoved(const std::string& command, const std::string& option,
                                const std::filesystem::path& dir) {
  std::error_code ec;
  if (std::filesystem::is_directory(dir, ec)) return;
  if (std::filesystem::exists(std::filesystem::symlink_status(dir, ec))) {
    std::fprintf(stderr,
                 "dygslam %s: warning: --%s '%s' was replaced by something that is not a folder "
                 "while the command ran; the outputs cannot be written there\n",
                 command.c_str(), option.c_str(), EchoValue(dir.string()).c_str());
    return;
  }
  std::fprintf(stderr,
               "dygslam %s: warning: --%s '%s' was removed while the command ran; made it again "
               "for the outputs\n",
               command.c_str(), option.c_str(), EchoValue(dir.string()).c_str());
  std::filesystem::create_directories(dir, ec);  // failing: the first write names the file
}

}  // namespace dygslam
