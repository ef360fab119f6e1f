#include "run/realtime_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "core/base/error.h"
#include "core/io/file_util.h"

namespace dygslam {

std::string RealtimeReport::Summary() const {
  char line[256];
  std::snprintf(line, sizeof(line),
                "rate %.2fx: %zu frames, %zu dropped, %zu late; latency median %.1f ms, 99th "
                "percentile %.1f ms",
                rate, frames, dropped(), late, latency_median_ms, latency_p99_ms);
  std::string text = line;
  if (Stalled()) {
    std::snprintf(line, sizeof(line),
                  "; stalled: no result for %.1f s while frames arrived (a component paused or "
                  "stopped)",
                  longest_gap_s);
    text += line;
  }
  return text;
}

RealtimeReport MakeRealtimeReport(double rate, size_t frames,
                                  const std::vector<ResultLatency>& latencies,
                                  double late_after_ms) {
  RealtimeReport r;
  r.rate = rate;
  r.frames = frames;
  r.results = latencies.size();
  r.latencies.assign(latencies.begin(),
                     latencies.begin() + std::min(latencies.size(), kMaxLatencyRows));
  std::vector<double> sorted;
  sorted.reserve(latencies.size());
  for (const ResultLatency& l : latencies) sorted.push_back(l.ms);
  std::sort(sorted.begin(), sorted.end());
  auto quantile = [&](double q) {
    if (sorted.empty()) return 0.0;
    const size_t i = std::min(sorted.size() - 1, static_cast<size_t>(q * sorted.size()));
    return sorted[i];
  };
  r.latency_median_ms = quantile(0.5);
  r.latency_p99_ms = quantile(0.99);
  if (late_after_ms > 0)
    r.late = static_cast<size_t>(
        std::count_if(sorted.begin(), sorted.end(), [&](double ms) { return ms > late_after_ms; }));
  return r;
}

void WriteRealtimeReport(const std::string& path, const RealtimeReport& r) {
  std::ostringstream out;
  out << "rate " << r.rate << "\nframes " << r.frames << "\nresults " << r.results << "\nlate "
      << r.late << "\nlatency_median_ms " << r.latency_median_ms << "\nlatency_p99_ms "
      << r.latency_p99_ms << "\nlongest_gap_s " << r.longest_gap_s << "\n";
  char line[96];
  for (const ResultLatency& l : r.latencies) {
    std::snprintf(line, sizeof(line), "latency %s %.3f\n", l.stamp.ToString().c_str(), l.ms);
    out << line;
  }
  WriteFileAtomically(path, out.str());
}

RealtimeReport ReadRealtimeReport(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot be read");
  RealtimeReport r;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (line.empty()) continue;
    std::istringstream fields(line);
    std::string key;
    if (line.rfind("latency ", 0) == 0) {
      std::string stamp_text;
      double ms = -1;
      std::string rest;
      fields >> key >> stamp_text >> ms;
      const std::optional<Timestamp> stamp = Timestamp::Parse(stamp_text);
      if (!stamp || !fields || !std::isfinite(ms) || ms < 0 || (fields >> rest))
        throw InputError(path + ":" + std::to_string(n) +
                         ": expected 'latency <stamp> <milliseconds>', got '" + line + "'");
      r.latencies.push_back({*stamp, ms});
      continue;
    }
    double value = 0;
    if (!(fields >> key >> value) || value < 0)
      throw InputError(path + ":" + std::to_string(n) + ": expected 'key value', got '" + line +
                       "'");
    if (key == "rate") r.rate = value;
    if (key == "frames") r.frames = static_cast<size_t>(value);
    if (key == "results") r.results = static_cast<size_t>(value);
    if (key == "late") r.late = static_cast<size_t>(value);
    if (key == "latency_median_ms") r.latency_median_ms = value;
    if (key == "latency_p99_ms") r.latency_p99_ms = value;
    if (key == "longest_gap_s") r.longest_gap_s = value;
  }
  return r;
}

}  // namespace dygslam
