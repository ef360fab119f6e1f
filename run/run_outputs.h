// What a run writes, written once: frames.csv (one column layout for `dygslam run` in
// every mode: the direct loop and the pipeline's recorder component), the TUM trajectories of a
// System and the map of a KeyframeMapper.
//
// frames.csv: stamp,state,keyframe,features,dynamic,tracked,orb_ms,detection_ms,matching_ms,
//             probability_ms,tracking_ms,total_ms,detection_wait_ms,local_mapping_ms,top_up_ms
//             (stage times in ms, StageTimes). The same layout for `dygslam run` in every mode
//             and for `dygslam bench`'s runs.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/base/timestamp.h"
#include "core/base/types.h"
#include "core/io/file_util.h"
#include "core/system/system.h"
#include "mapping/octomap_builder.h"

namespace dygslam {

class KeyframeMapper;  // mapping/keyframe_mapper.h

// One frames.csv line: what the System reported for a frame (FrameResult, or the CameraPose
// message that carries it between components).
struct FrameRow {
  Timestamp stamp;
  TrackingState state = TrackingState::kNotInitialized;
  bool is_keyframe = false;
  int num_features = 0;
  int num_dynamic = 0;
  int num_tracked = 0;
  StageTimes times;
};

// The output files of one run, transactional: each is written under a temporary name in its
// folder and renamed over the old one only when complete (WriteFileAtomically); nothing is
// deleted up front, so a file an earlier run left stays until this run's replacement is complete.
// The versions taken at construction tell this run's files (replaced since: a rename is a new
// inode, also when another process of the run wrote it) from an earlier run's. A write that fails
// is recorded with its reason and does not stop the others; the command reports the failures at
// the end and exits 1.
class RunOutputs {
 public:
  // `names`: the files this run may write into `directory` (trajectory.txt, map.bt, ...).
  RunOutputs(std::filesystem::path directory, std::vector<std::string> names);
  // An output outside the folder (--save-map FILE): tracked like the others, named by its path.
  void AddFile(const std::string& path);

  const std::filesystem::path& directory() const { return directory_; }
  std::string PathOf(const std::string& name) const;  // DIR/name, or the path of AddFile
  // Runs `write` (which writes output `name`); an exception is recorded as a failure of `name`
  // with its message and false is returned.
  bool Write(const std::string& name, const std::function<void()>& write);
  void RecordFailure(const std::string& name, const std::string& reason);
  // `name` was written by this run: its file was replaced (or created) since construction, in
  // the folder it was to go into (a folder replaced while the run went, by a link to another
  // folder say, holds files this run did not write).
  bool Fresh(const std::string& name) const;
  // `name` is there, in its folder, and was not written by this run.
  bool Stale(const std::string& name) const;
  // The tracked names written by this run / present but left from before it, in the order given.
  std::vector<std::string> FreshNames() const;
  std::vector<std::string> StaleNames() const;
  const std::vector<std::pair<std::string, std::string>>& failures() const { return failures_; }
  // Throws std::runtime_error "NAME not written: REASON" for the first failure, if any (for a
  // writer whose caller stops at a failed output once every other is written).
  void ThrowIfAnyFailed() const;
  // "dygslam COMMAND: error: NAME not written: REASON" lines for stderr ("" when none failed).
  std::string FailureReport(const std::string& command) const;

 private:
  bool InItsFolder(const std::string& name) const;  // the folder is still the one it was

  std::filesystem::path directory_;
  std::vector<std::string> names_;
  std::map<std::string, std::string> paths_;  // name -> path of the files of AddFile
  long long started_ns_ = 0;                  // construction, as a file time
  std::map<std::string, FileVersion> before_;
  std::map<std::string, FileVersion> folder_before_;           // name -> its folder at construction
  std::vector<std::pair<std::string, std::string>> failures_;  // name, reason
};

// The files a run writes into its --out folder (trajectories, frames.csv, maps, reports,
// eval.json), and those the summary lists.
const std::vector<std::string>& RunOutputNames();
// Before a command writes its outputs into `dir` (given as --<option>): a folder removed while the
// command ran (a cleanup script, `rm -rf` by hand) is made again with a warning on stderr naming
// the option, so the outputs of the work done are not lost.
void RecreateOutputDirIfRemoved(const std::string& command, const std::string& option,
                                const std::filesystem::path& dir);

FrameRow FrameRowFromResult(const FrameResult& result);
std::string FramesCsvHeader();
std::string FramesCsvRow(const FrameRow& row);
// The rows of a frames.csv, columns found by the header's names (a stage column the file lacks
// reads 0). Throws InputError naming the file and line for a missing stamp/state column, an
// unknown state, a malformed stamp or number.
std::vector<FrameRow> ReadFramesCsv(const std::string& path);

// What a run produced, held until its end: the one form in which every way of running (the
// direct loop, the recorder component, the bench worker, `dygslam map`) hands its results to
// WriteRunRecord, so the files have one layout and one writer. A part left unset is not written.
struct RunRecord {
  std::optional<std::vector<FrameRow>> rows;          // frames.csv, in frame order
  std::vector<StampedPose> trajectory;                // trajectory.txt: final, refined
  std::optional<std::vector<StampedPose>> online;     // trajectory_online.txt
  std::optional<std::vector<StampedPose>> keyframes;  // keyframes.txt
  bool HasFrames() const;                             // a row or a pose of a frame
};
// The final trajectory and the keyframes of a System.
RunRecord RunRecordOfSystem(const System& system);
// Writes the record's files through `outputs`, each atomically; a failed write is recorded under
// its name and the others are still written. A record without a frame (a run stopped or failed
// before its first) leaves an earlier run's trajectory.txt and the files beside it as they were,
// and returns false; where there is none, the empty (loadable) files are written.
bool WriteRunRecord(RunOutputs& outputs, const RunRecord& record);
// Waits for the mapper's queue, then writes DIR/map.bt when the map has a keyframe or a loaded
// base map (and DIR/map.ot, the OctoMap with probabilities, with `with_full_map`).
// Each file through `outputs` (a failure is recorded under its own name).
void WriteMapperBinary(RunOutputs& outputs, KeyframeMapper& mapper, bool with_full_map = false);

// The static map of a SLAM map file (--load-map) as DIR/map.bt, for a run that added no keyframe
// of its own (--localization): the file's map points, each inserted by ray casting from the
// centre of every keyframe that observes it (free space cleared along the ray), with the sensor
// model and range of `octomap`. The map file is read against `options` like CheckMapFile. Returns
// the number of map points inserted (0: nothing written).
size_t WriteMapFileOctoMap(const std::string& directory, const std::string& map_file,
                           const SystemOptions& options, const OctoMapOptions& octomap,
                           bool with_full_map = false);

}  // namespace dygslam
