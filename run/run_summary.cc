#include "run/run_summary.h"

#include <algorithm>
#include <cstdio>
#include <sstream>

#include "core/base/json.h"

namespace dygslam {

const char* ToString(Shortfall shortfall) {
  switch (shortfall) {
    case Shortfall::kNone:
      return "none";
    case Shortfall::kStoppedByUser:
      return "stopped by the user (a stop signal)";
    case Shortfall::kDroppedByRate:
      return "dropped: the pipeline could not take them at the camera's rate (--rate)";
    case Shortfall::kComponentFailed:
      return "a pipeline component failed";
    case Shortfall::kForeignFrames:
      return "frames that are not this run's were processed, or frames twice (another frame "
             "source or a second slam on the run's DDS partition: the outputs mix two streams)";
    case Shortfall::kComponentCutShort:
      return "a component ended before the run did (stopped by a signal sent to it alone, or its "
             "input ended without the end of the run), or what it published did not all arrive: "
             "its part of the outputs is incomplete";
    case Shortfall::kCutShort:
      return "the stream was cut short (a component stopped or stalled, or an end of stream came "
             "from outside the run)";
  }
  return "unknown";
}

size_t RunSummary::WithPose() const {
  size_t n = 0;
  for (const char* state : {"ok", "fallback", "relocalized"}) {
    const auto it = states.find(state);
    if (it != states.end()) n += it->second;
  }
  return n;
}

Shortfall RunSummary::Reason() const {
  if (foreign_frames > 0) return Shortfall::kForeignFrames;
  if (component_failed || !error.empty()) return Shortfall::kComponentFailed;
  if (!components_cut_short.empty()) return Shortfall::kComponentCutShort;
  if (Missing() == 0 && !loop_ended_early) return Shortfall::kNone;
  if (interrupted) return Shortfall::kStoppedByUser;
  // The camera's pace explains the frames the pipeline dropped, not more.
  if (realtime && !loop_ended_early && Missing() <= realtime->dropped() && !realtime->Stalled())
    return Shortfall::kDroppedByRate;
  return Shortfall::kCutShort;
}

namespace {

std::string AteJson(const std::optional<AteFigures>& ate) {
  if (!ate) return "null";
  std::ostringstream j;
  j << "{\"rmse\": " << JsonNumber(ate->rmse) << ", \"mean\": " << JsonNumber(ate->mean)
    << ", \"median\": " << JsonNumber(ate->median) << ", \"max\": " << JsonNumber(ate->max)
    << ", \"pairs\": " << ate->pairs << "}";
  return j.str();
}

}  // namespace

std::string RunSummaryJson(const RunSummary& s) {
  std::ostringstream j;
  j << "{\"mode\": " << JsonString(s.mode) << ", \"filter\": " << JsonString(s.filter)
    << ", \"deterministic\": " << (s.deterministic ? "true" : "false") << ",\n";
  j << " \"frames\": {\"first\": " << s.first << ", \"last\": " << s.last
    << ", \"requested\": " << s.requested
    << ", \"without_depth_partner\": " << s.without_depth_partner
    << ", \"processed\": " << s.processed << ", \"foreign\": " << s.foreign_frames
    << ", \"with_pose\": " << s.WithPose() << ", \"in_trajectory\": " << s.in_trajectory
    << ", \"missing\": " << s.Missing() << ", \"states\": {";
  bool first = true;
  for (const auto& [state, count] : s.states) {
    j << (first ? "" : ", ") << JsonString(state) << ": " << count;
    first = false;
  }
  j << "}},\n";
  j << " \"complete\": " << (s.Complete() ? "true" : "false")
    << ", \"shortfall\": " << JsonString(ToString(s.Reason()))
    << ", \"interrupted\": " << (s.interrupted ? "true" : "false")
    << ", \"fps\": " << JsonNumber(s.seconds > 0 ? s.processed / s.seconds : 0) << ",\n";
  j << " \"realtime\": ";
  if (s.realtime) {
    const RealtimeReport& r = *s.realtime;
    j << "{\"rate\": " << JsonNumber(r.rate) << ", \"frames\": " << r.frames
      << ", \"dropped\": " << r.dropped() << ", \"late\": " << r.late
      << ", \"latency_median_ms\": " << JsonNumber(r.latency_median_ms)
      << ", \"latency_p99_ms\": " << JsonNumber(r.latency_p99_ms)
      << ", \"longest_gap_s\": " << JsonNumber(r.longest_gap_s) << "}";
  } else {
    j << "null";
  }
  j << ",\n \"ate\": " << AteJson(s.ate) << ",\n \"online_ate\": " << AteJson(s.online_ate)
    << ",\n \"ate_note\": " << JsonString(s.ate_note)
    << ", \"ignored_samples\": " << s.ignored_samples << ", \"components_cut_short\": [";
  for (size_t i = 0; i < s.components_cut_short.size(); ++i)
    j << (i == 0 ? "" : ", ") << JsonString(s.components_cut_short[i]);
  j << "], \"error\": " << JsonString(s.error) << ", \"exit_code\": " << s.exit_code << "}\n";
  return j.str();
}

bool IsTrackingFailure(size_t processed, size_t tracked) {
  return processed == 0 || tracked * 10 < processed;
}

void PrintTrackingFailure(const std::string& command, size_t processed, size_t tracked,
                          size_t lost) {
  if (processed == 0) {
    std::fprintf(stderr,
                 "dygslam %s: error: no frame was processed (no rgb entry of the range has a "
                 "depth partner)\n",
                 command.c_str());
    return;
  }
  const size_t untracked = processed - std::min(processed, tracked);
  std::fprintf(stderr,
               "dygslam %s: error: tracking failed: %zu of %zu frames tracked (%.1f %%, at least "
               "10 %% needed); %zu lost after initialisation, %zu never tracked. Likely causes: "
               "depth images without valid depth (DepthMapFactor), camera settings that do not "
               "match the images (Camera.*), or images without texture.\n",
               command.c_str(), tracked, processed, 100.0 * tracked / processed,
               std::min(lost, untracked), untracked - std::min(lost, untracked));
}

}  // namespace dygslam
