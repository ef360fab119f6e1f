// What a `dygslam run` delivered, for people (the summary lines) and for scripts (OUT/eval.json):
// the frames requested, received and tracked, why any are missing, the accuracy of the final and
// of the online trajectory, and the run's exit code.
//
//   RunSummary summary;  // filled by the command as the run ends
//   WriteFileAtomically(out + "/eval.json", RunSummaryJson(summary));
#pragma once

#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "run/realtime_report.h"

namespace dygslam {

// A run: the stream ended before every requested frame was processed, and no stop signal asked
// for that (a component stopped or stalled, an end of stream from outside the run).
inline constexpr int kExitIncompleteRun = 3;

// A SLAM run that processed no frame or tracked fewer than 10 % of them failed (exit 1), even when
// every part of it ran: its trajectory says nothing.
bool IsTrackingFailure(size_t processed, size_t tracked);
// "dygslam <command>: error: tracking failed: 0 of 30 frames tracked ..." with the likely causes.
void PrintTrackingFailure(const std::string& command, size_t processed, size_t tracked,
                          size_t lost);

// ATE figures of one trajectory against the ground truth (metres).
struct AteFigures {
  double rmse = 0, mean = 0, median = 0, max = 0;
  size_t pairs = 0;
};

// Why a run delivered fewer frames than it was asked for.
enum class Shortfall {
  kNone,               // every requested frame was processed
  kStoppedByUser,      // SIGINT / SIGTERM / SIGHUP: the user's stop
  kDroppedByRate,      // --rate: frames the pipeline could not take in time (by design, counted)
  kComponentFailed,    // a pipeline component failed, or the run stopped on an error (its message
                       // is on stderr and in RunSummary::error)
  kForeignFrames,      // frames of another frame source on the run's DDS partition were processed
  kComponentCutShort,  // a component ended before the run did (--processes: a stop signal sent to
                       // it alone, or its input ended without the end of the run): its part of
                       // the outputs (the map, the detections) ends early
  kCutShort            // the stream ended early: a component stopped or stalled, or an end of
                       // stream came from outside the run
};
const char* ToString(Shortfall shortfall);

struct RunSummary {
  std::string mode;    // "direct (no DDS)", "DDS pipeline, one process", ...
  std::string filter;  // none | boxes | geometry | paper | full
  bool deterministic = false;
  size_t first = 0, last = 0;              // rgb.txt entries [first, last)
  size_t requested = 0;                    // of them, frames with a depth partner
  size_t without_depth_partner = 0;        // entries left out: no depth image to pair with
  size_t processed = 0;                    // frames of this run the SLAM processed
  size_t foreign_frames = 0;               // frames processed that are not this run's (DDS)
  std::map<std::string, size_t> states;    // frames by tracking state (ok, fallback, lost, ...)
  size_t in_trajectory = 0;                // frames in trajectory.txt
  double seconds = 0;                      // wall time of the frames
  std::optional<RealtimeReport> realtime;  // --rate
  std::optional<AteFigures> ate, online_ate;
  std::string ate_note;        // why no ATE ("" when there is one or no ground truth)
  size_t ignored_samples = 0;  // DDS samples of participants outside the run
  bool interrupted = false;    // a stop signal ended the run
  bool component_failed = false;
  // --processes: components that ended before the run did, with why ("mapper (signal 15)").
  std::vector<std::string> components_cut_short;
  bool loop_ended_early = false;  // --loop-minutes: the replay ended before its time was up
  std::string error;              // the error that stopped the run ("" when none)
  int exit_code = 0;

  // Frames with a pose: ok + fallback + relocalized.
  size_t WithPose() const;
  size_t Missing() const { return requested > processed ? requested - processed : 0; }
  // Every requested frame processed and nothing else, and the run did not fail.
  bool Complete() const {
    return Missing() == 0 && foreign_frames == 0 && !component_failed && error.empty() &&
           components_cut_short.empty() && !loop_ended_early;
  }
  // Why frames are missing (kNone when none are).
  Shortfall Reason() const;
};

// One JSON object:
// {"mode": ..., "filter": ..., "deterministic": ..., "frames": {"first", "last", "requested",
//  "without_depth_partner", "processed", "foreign", "with_pose", "in_trajectory", "missing",
//  "states": {..}},
//  "complete": bool, "shortfall": "none" | "stopped by the user" | ..., "fps": ...,
//  "realtime": {...} | null, "ate": {"rmse", "mean", "median", "max", "pairs"} | null,
//  "online_ate": {...} | null, "ate_note": "...", "ignored_samples": N,
//  "components_cut_short": [...], "error": "...",
//  "exit_code": N}
std::string RunSummaryJson(const RunSummary& summary);

}  // namespace dygslam
