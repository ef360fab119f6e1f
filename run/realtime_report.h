// What a paced run (`dygslam run --rate R`: frames arrive as from a camera) measured: frames that
// arrived, frames the pipeline did not take (dropped), results that came more than
// kLateFramePeriods frame periods after their frame arrived (late), and the frame-to-pose
// latency. The DDS player writes it to OUT/realtime.txt; the direct loop fills it itself.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

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

struct RealtimeReport {
  double rate = 0;     // times the dataset's frame rate
  size_t frames = 0;   // frames that arrived
  size_t results = 0;  // of them, frames with a result (a pose or a lost state)
  size_t late = 0;     // results later than kLateFramePeriods frame periods
  double latency_median_ms = 0;
  double latency_p99_ms = 0;
  double longest_gap_s = 0;  // the longest time without a result while frames arrived
  size_t dropped() const { return frames > results ? frames - results : 0; }
  bool Stalled() const { return longest_gap_s > kStallSeconds; }
  // "rate 1.0x: 360 frames, 0 dropped, 0 late; latency median 31.2 ms, 99th percentile 52.0 ms"
  std::string Summary() const;
};

// The report of per-result latencies (ms) and `late_after_ms` (0: nothing is late).
RealtimeReport MakeRealtimeReport(double rate, size_t frames, const std::vector<double>& latency_ms,
                                  double late_after_ms);

// Key-value text, one per line ("frames 360"); written atomically.
void WriteRealtimeReport(const std::string& path, const RealtimeReport& report);
// Throws InputError naming the file and the line for a malformed file.
RealtimeReport ReadRealtimeReport(const std::string& path);

}  // namespace dygslam
