// What a paced run (`dygslam run --rate R`: frames arrive as from a camera) measured: frames that
// arrived, frames the pipeline did not take (dropped), results that came more than
// kLateFramePeriods frame periods after their frame arrived (late), and the frame-to-pose
// latency. The DDS player writes it to OUT/realtime.txt; the direct loop fills it itself.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "core/base/timestamp.h"

namespace dygslam {

inline constexpr const char* kRealtimeReportFile = "realtime.txt";
// A result is late when it comes more than this many frame periods after its frame arrived: the
// pipeline is then behind the camera, not just pipelined.
inline constexpr double kLateFramePeriods = 3.0;

// A stretch this long without any result while frames kept arriving is a stall (a component
// paused or stopped), not the pipeline falling behind the camera: the frames dropped then are not
// explained by the camera's pace. The longest designed wait of a frame is slam's wait for its
// detections (1 s) plus its processing; runs undisturbed at the camera's rate measure 0.1 s
// (0.2 s with two runs on two cores), slam paused for 2 s measures 2.1 s.
inline constexpr double kStallSeconds = 1.5;

// The latency of each result is kept for the report up to this many results (about 9 hours at
// 30 Hz, 16 MB); the counts and quantiles cover every result.
inline constexpr size_t kMaxLatencyRows = 1000000;

// One result: the stamp of its frame and the time from the frame's arrival to its result.
struct ResultLatency {
  Timestamp stamp;
  double ms = 0;
};

struct RealtimeReport {
  double rate = 0;     // times the dataset's frame rate
  size_t frames = 0;   // frames that arrived
  size_t results = 0;  // of them, frames with a result (a pose or a lost state)
  size_t late = 0;     // results later than kLateFramePeriods frame periods
  double latency_median_ms = 0;
  double latency_p99_ms = 0;
  double longest_gap_s = 0;  // the longest time without a result while frames arrived
  // Per result in the order the results came (at most kMaxLatencyRows): where in the sequence the
  // latency builds up (a crowd, a burst of keyframes), beside frames.csv's stage times.
  std::vector<ResultLatency> latencies;
  size_t dropped() const { return frames > results ? frames - results : 0; }
  bool Stalled() const { return longest_gap_s > kStallSeconds; }
  // "rate 1.0x: 360 frames, 0 dropped, 0 late; latency median 31.2 ms, 99th percentile 52.0 ms"
  std::string Summary() const;
};

// The report of per-result latencies and `late_after_ms` (0: nothing is late).
RealtimeReport MakeRealtimeReport(double rate, size_t frames,
                                  const std::vector<ResultLatency>& latencies,
                                  double late_after_ms);

// Key-value text, one per line ("frames 360"), then one line per result:
// "latency <stamp> <ms>" ("latency 1548339823.897980 31.250"); written atomically.
void WriteRealtimeReport(const std::string& path, const RealtimeReport& report);
// Throws InputError naming the file and the line for a malformed file.
RealtimeReport ReadRealtimeReport(const std::string& path);

}  // namespace dygslam
