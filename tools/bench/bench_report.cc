#include "tools/bench/bench_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>

#include "core/base/error.h"
#include "core/io/file_util.h"

namespace dygslam {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string Fixed(double v, int digits) {
  if (!std::isfinite(v)) return "-";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", digits, v);
  return buf;
}

std::string Percent(double v) {
  if (!std::isfinite(v)) return "-";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.2f %%", v);
  return buf;
}

bool IsFilterConfig(const std::string& config) { return config != kBaselineConfig; }
// Configurations that use person boxes / the epipolar geometry.
bool UsesBoxes(const std::string& c) {
  return c == "boxes" || c == "full" || c.rfind("paper", 0) == 0;
}
bool UsesGeometry(const std::string& c) {
  return c == "geometry" || c == "full" || c.rfind("paper", 0) == 0;
}
// " ‡" when the row's boxes came from the sequence's detections.txt instead of the detector.
std::string FileBoxesMark(const BenchContext& context, const std::string& seq,
                          const std::string& config) {
  const auto& f = context.file_detection_sequences;
  return UsesBoxes(config) && std::find(f.begin(), f.end(), seq) != f.end() ? " ‡" : "";
}

// Columns of the runs CSV, in order.
const std::vector<std::string>& CsvColumns() {
  static const std::vector<std::string> columns = {"sequence",
                                                   "config",
                                                   "run",
                                                   "trajectory",
                                                   "frames",
                                                   "poses",
                                                   "lost",
                                                   "ate_pairs",
                                                   "ate_rmse",
                                                   "ate_mean",
                                                   "ate_median",
                                                   "ate_sd",
                                                   "ate_min",
                                                   "ate_max",
                                                   "orb_ms",
                                                   "detection_ms",
                                                   "detection_wait_ms",
                                                   "matching_ms",
                                                   "probability_ms",
                                                   "tracking_ms",
                                                   "local_mapping_ms",
                                                   "total_ms",
                                                   "median_total_ms",
                                                   "loop_seconds",
                                                   "fps",
                                                   "peak_rss_mib"};
  return columns;
}

std::string Num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.9g", v);
  return buf;
}

}  // namespace

std::string ConfigLabel(const std::string& config) {
  if (config == "none") return "no filter (our tracker)";
  if (config == "boxes") return "box removal only";
  if (config == "geometry") return "geometry only";
  if (config == "paper") return "paper's method (DYG-SLAM as written)";
  if (config == "paper+margin") return "paper + box margin";
  if (config == "paper+margin+demotion") return "paper + box margin + in-box demotion";
  if (config == "full") return "full method (ours: paper + margin + demotion + re-extraction)";
  if (config == kBaselineConfig) return "cv::rgbd::RgbdICPOdometry (baseline)";
  return config;
}

double Median(std::vector<double> values) {
  values.erase(
      std::remove_if(values.begin(), values.end(), [](double v) { return !std::isfinite(v); }),
      values.end());
  if (values.empty()) return kNaN;
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

double Improvement(double eta, double mu) {
  if (!std::isfinite(eta) || !std::isfinite(mu) || mu <= 0) return kNaN;
  return (1.0 - eta / mu) * 100.0;
}

ErrorStatistics AteOnFrameSet(const std::vector<StampedPose>& groundtruth,
                              const std::vector<StampedPose>& estimate,
                              const std::vector<StampedPose>& frame_set) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  std::set<int64_t> stamps;  // microseconds (TUM files keep 6 decimals)
  for (const StampedPose& p : frame_set) stamps.insert(std::llround(p.stamp.nanoseconds() / 1e3));
  std::vector<StampedPose> kept;
  for (const StampedPose& p : estimate)
    if (stamps.count(std::llround(p.stamp.nanoseconds() / 1e3))) kept.push_back(p);
  try {
    const AteResult ate = ComputeAte(groundtruth, kept);
    if (ate.num_pairs >= 3) return ate.error;
  } catch (const std::exception&) {
  }
  return ErrorStatistics{kNaN, kNaN, kNaN, kNaN, kNaN, kNaN};
}

void SetReferenceAte(const std::vector<StampedPose>& groundtruth,
                     const std::vector<std::vector<StampedPose>>& no_filter_trajectories,
                     const std::vector<StampedPose>& frame_set, BenchCell* cell) {
  std::vector<double> rmse, mean, sd;
  for (const auto& trajectory : no_filter_trajectories) {
    const ErrorStatistics e = AteOnFrameSet(groundtruth, trajectory, frame_set);
    rmse.push_back(e.rmse);
    mean.push_back(e.mean);
    sd.push_back(e.sd);
  }
  cell->reference_ate = ErrorStatistics{};
  cell->reference_ate.rmse = Median(rmse);
  cell->reference_ate.mean = Median(mean);
  cell->reference_ate.sd = Median(sd);
  cell->has_reference_ate = std::isfinite(cell->reference_ate.rmse);
}

BenchCell Summarize(const std::vector<BenchRun>& runs) {
  if (runs.empty()) throw std::invalid_argument("Summarize: no runs");
  BenchCell cell;
  cell.sequence = runs[0].sequence;
  cell.config = runs[0].config;
  cell.num_runs = static_cast<int>(runs.size());
  for (const BenchRun& r : runs) {
    if (r.sequence != cell.sequence || r.config != cell.config)
      throw std::invalid_argument("Summarize: runs of different sequences/configurations");
  }
  auto median_of = [&](auto field) {
    std::vector<double> v;
    for (const BenchRun& r : runs) v.push_back(static_cast<double>(field(r)));
    return Median(v);
  };
  cell.ate.rmse = median_of([](const BenchRun& r) { return r.ate.rmse; });
  cell.ate.mean = median_of([](const BenchRun& r) { return r.ate.mean; });
  cell.ate.median = median_of([](const BenchRun& r) { return r.ate.median; });
  cell.ate.sd = median_of([](const BenchRun& r) { return r.ate.sd; });
  cell.ate.min = median_of([](const BenchRun& r) { return r.ate.min; });
  cell.ate.max = median_of([](const BenchRun& r) { return r.ate.max; });
  cell.ate_pairs = median_of([](const BenchRun& r) { return r.ate_pairs; });
  cell.frames = median_of([](const BenchRun& r) { return r.frames; });
  cell.poses = median_of([](const BenchRun& r) { return r.poses; });
  cell.lost = median_of([](const BenchRun& r) { return r.lost; });
  cell.stages.orb_ms = median_of([](const BenchRun& r) { return r.stages.orb_ms; });
  cell.stages.detection_ms = median_of([](const BenchRun& r) { return r.stages.detection_ms; });
  cell.stages.detection_wait_ms =
      median_of([](const BenchRun& r) { return r.stages.detection_wait_ms; });
  cell.stages.matching_ms = median_of([](const BenchRun& r) { return r.stages.matching_ms; });
  cell.stages.probability_ms = median_of([](const BenchRun& r) { return r.stages.probability_ms; });
  cell.stages.tracking_ms = median_of([](const BenchRun& r) { return r.stages.tracking_ms; });
  cell.stages.local_mapping_ms =
      median_of([](const BenchRun& r) { return r.stages.local_mapping_ms; });
  cell.stages.total_ms = median_of([](const BenchRun& r) { return r.stages.total_ms; });
  cell.stages.median_total_ms =
      median_of([](const BenchRun& r) { return r.stages.median_total_ms; });
  cell.fps = median_of([](const BenchRun& r) { return r.fps; });
  cell.peak_rss_mib = median_of([](const BenchRun& r) { return r.peak_rss_mib; });
  std::vector<int> order(runs.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  // Failed runs (no ATE) sort last and are not picked unless every run failed.
  auto key = [&](int i) {
    return std::isfinite(runs[i].ate.rmse) ? runs[i].ate.rmse
                                           : std::numeric_limits<double>::infinity();
  };
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return key(a) < key(b); });
  int finite = 0;
  for (const BenchRun& r : runs) finite += std::isfinite(r.ate.rmse) ? 1 : 0;
  cell.num_failed = cell.num_runs - finite;
  if (finite > 0) order.resize(finite);
  cell.median_run = order[(order.size() - 1) / 2];
  cell.rmse_min = finite > 0 ? runs[order.front()].ate.rmse : kNaN;
  cell.rmse_max = finite > 0 ? runs[order.back()].ate.rmse : kNaN;
  return cell;
}

std::string RenderBenchMarkdown(const BenchContext& context, const std::vector<BenchCell>& cells,
                                const std::vector<SequencePictures>& pictures,
                                const std::string& image_prefix) {
  // Sequences in order of first appearance; configurations in context order, baseline last.
  std::vector<std::string> sequences;
  for (const BenchCell& c : cells) {
    if (std::find(sequences.begin(), sequences.end(), c.sequence) == sequences.end())
      sequences.push_back(c.sequence);
  }
  std::vector<std::string> configs;
  for (const std::string& c : context.configs)
    if (c != kBaselineConfig) configs.push_back(c);
  for (const BenchCell& c : cells) {
    if (c.config != kBaselineConfig &&
        std::find(configs.begin(), configs.end(), c.config) == configs.end())
      configs.push_back(c.config);
  }
  bool has_baseline = false;
  for (const BenchCell& c : cells) has_baseline |= c.config == kBaselineConfig;
  if (has_baseline) configs.push_back(kBaselineConfig);
  auto find = [&](const std::string& seq, const std::string& config) -> const BenchCell* {
    for (const BenchCell& c : cells)
      if (c.sequence == seq && c.config == config) return &c;
    return nullptr;
  };

  std::ostringstream md;
  md << "<!-- Generated by `dygslam bench`; do not edit by hand: re-run the command below. -->\n\n";
  md << "Measured by us with\n\n```\n" << context.command_line << "\n```\n\n";
  md << "- date: " << context.date << "; dygslam " << context.version << "\n";
  md << "- machine: " << context.machine << "\n";
  md << "- load average during the benchmark: " << context.load
     << " (other jobs sharing the cores slow the timings, not the accuracy)\n";
  md << "- " << context.runs << " run" << (context.runs == 1 ? "" : "s")
     << " per sequence and configuration, median reported"
     << (context.deterministic ? "; deterministic mode (fixed seeds, local mapping synchronous)"
                               : "; real threading (local mapping on its own thread)")
     << (context.quick ? "; **--quick mode (development figures, not for publication)**" : "")
     << "\n";
  md << "- frames: " << (context.frames.empty() ? "all" : context.frames) << "; data: `"
     << context.data_dir << "`\n";
  md << "- ATE: timestamp association within 0.02 s, rigid SE(3) alignment of the estimate onto "
        "groundtruth.txt (no scale), as `dygslam eval` (TUM benchmark conventions); for Bonn the "
        "ground truth is the marker body, without the marker-to-camera calibration\n";
  md << "- published figures for context (the paper and others) are quoted apart, in "
        "BENCHMARKS.md, *Published figures*: they were not measured by us\n";
  for (const std::string& note : context.notes) md << "- " << note << "\n";
  for (const std::string& seq : context.file_detection_sequences)
    md << "- ‡ " << seq
       << ": person boxes read from the sequence's `detections.txt` (ground-truth "
          "boxes of a generated sequence), not produced by the detector; rows marked ‡\n";
  md << "\n";

  // Paper layout (Tables 1-2): no filter vs full method, improvement.
  const bool has_pair = std::find(configs.begin(), configs.end(), "none") != configs.end() &&
                        std::find(configs.begin(), configs.end(), "full") != configs.end();
  md << "### Accuracy (layout of the paper's Tables 1-2)\n\n";
  md << "ATE in metres over all frames with a pose (ok, fallback or relocalized; poses / frames "
        "beside it), median over runs. γ = (1 − η/μ) × 100 %: η = the configuration, μ = no "
        "filter (our tracker) on the same frame set: its ATE over only the frames the "
        "configuration has a pose for.\n\n";
  // μ of a configuration: the no-filter ATE on the configuration's frames when known.
  auto mu = [](const BenchCell& c, const BenchCell& none) {
    return c.has_reference_ate ? c.reference_ate : none.ate;
  };
  if (has_pair) {
    md << "| Sequence | no filter RMSE | Mean | S.D. | poses / frames | full method RMSE | Mean | "
          "S.D. | poses / frames | γ RMSE | γ Mean | γ S.D. |\n";
    md << "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const std::string& seq : sequences) {
      const BenchCell* none = find(seq, "none");
      const BenchCell* full = find(seq, "full");
      if (!none || !full) continue;
      const ErrorStatistics m = mu(*full, *none);
      md << "| " << seq << " | " << Fixed(none->ate.rmse, 4) << " | " << Fixed(none->ate.mean, 4)
         << " | " << Fixed(none->ate.sd, 4) << " | " << Fixed(none->poses, 0) << " / "
         << Fixed(none->frames, 0) << " | " << Fixed(full->ate.rmse, 4) << " | "
         << Fixed(full->ate.mean, 4) << " | " << Fixed(full->ate.sd, 4) << " | "
         << Fixed(full->poses, 0) << " / " << Fixed(full->frames, 0) << " | "
         << Percent(Improvement(full->ate.rmse, m.rmse)) << " | "
         << Percent(Improvement(full->ate.mean, m.mean)) << " | "
         << Percent(Improvement(full->ate.sd, m.sd)) << " |\n";
    }
    md << "\n";
  }
  md << "All configurations (poses / frames: frames with a pose out of frames processed; the "
        "RMSE range is over the runs):\n\n";
  md << "| Sequence | Configuration | RMSE | Mean | S.D. | γ RMSE | γ Mean | γ S.D. | poses / "
        "frames | RMSE min – max |\n";
  md << "|---|---|---|---|---|---|---|---|---|---|\n";
  for (const std::string& seq : sequences) {
    const BenchCell* none = find(seq, "none");
    for (const std::string& config : configs) {
      const BenchCell* c = find(seq, config);
      if (!c) continue;
      md << "| " << seq << " | " << ConfigLabel(config) << FileBoxesMark(context, seq, config)
         << " | " << Fixed(c->ate.rmse, 4) << " | " << Fixed(c->ate.mean, 4) << " | "
         << Fixed(c->ate.sd, 4) << " | ";
      if (none && config != "none") {
        const ErrorStatistics m = mu(*c, *none);
        md << Percent(Improvement(c->ate.rmse, m.rmse)) << " | "
           << Percent(Improvement(c->ate.mean, m.mean)) << " | "
           << Percent(Improvement(c->ate.sd, m.sd)) << " | ";
      } else {
        md << "- | - | - | ";
      }
      md << Fixed(c->poses, 0) << " / " << Fixed(c->frames, 0) << " | " << Fixed(c->rmse_min, 4)
         << " – " << Fixed(c->rmse_max, 4) << " |\n";
    }
  }
  md << "\n";

  md << "### Time per frame (layout of the paper's Table 3)\n\n";
  md << "Mean milliseconds per frame, median over runs. ORB feature extraction includes the "
        "second extraction outside the boxes on crowded frames. Object detection runs on a second "
        "thread "
        "concurrently with ORB extraction, so its time overlaps; \"wait\" is the time tracking "
        "still waited for it. \"Total\" is the wall time of one frame through the system "
        "(`System::FeedRgbdFrame`, or one odometry step for the baseline), without image "
        "loading; local mapping runs on its own thread and is not part of it"
     << (context.deterministic ? " (deterministic mode: it is, column \"local mapping\")" : "")
     << ". \"Median\" is the median over the frames of that wall time, and \"× no filter\" its "
        "ratio to the no-filter row of the same bench run. frames/s = frames / wall time of the "
        "whole loop including image loading. Peak memory: maximum resident set of the run's "
        "process.\n\n";
  md << "| Sequence | System | ORB feature extraction | Object detection | (wait) | ORB feature "
        "matching | Update geometry probability | Tracking |"
     << (context.deterministic ? " Local mapping |" : "")
     << " Total time | Median | × no filter | frames/s | peak memory (MiB) |\n";
  md << "|---|---|---|---|---|---|---|---|" << (context.deterministic ? "---|" : "")
     << "---|---|---|---|---|\n";
  for (const std::string& seq : sequences) {
    for (const std::string& config : configs) {
      const BenchCell* c = find(seq, config);
      if (!c) continue;
      const StageMeans& s = c->stages;
      md << "| " << seq << " | " << ConfigLabel(config) << " | ";
      if (IsFilterConfig(config)) {
        const bool detects = UsesBoxes(config);
        const bool matches = UsesGeometry(config);
        md << Fixed(s.orb_ms, 2) << " | " << (detects ? Fixed(s.detection_ms, 2) : "-") << " | "
           << (detects ? Fixed(s.detection_wait_ms, 2) : "-") << " | "
           << (matches ? Fixed(s.matching_ms, 2) : "-") << " | "
           << (matches ? Fixed(s.probability_ms, 2) : "-") << " | " << Fixed(s.tracking_ms, 2)
           << " | ";
        if (context.deterministic) md << Fixed(s.local_mapping_ms, 2) << " | ";
      } else {
        md << "- | - | - | - | - | - | ";
        if (context.deterministic) md << "- | ";
      }
      const BenchCell* none = find(seq, "none");
      const bool ratio =
          none != nullptr && none->stages.median_total_ms > 0 && s.median_total_ms > 0;
      md << Fixed(s.total_ms, 2) << " | " << Fixed(s.median_total_ms, 2) << " | "
         << (ratio ? Fixed(s.median_total_ms / none->stages.median_total_ms, 2) : "-") << " | "
         << Fixed(c->fps, 1) << " | " << Fixed(c->peak_rss_mib, 0) << " |\n";
    }
  }
  md << "\n";

  if (!pictures.empty()) {
    md << "### Pictures\n\n";
    for (const SequencePictures& p : pictures) {
      md << "**" << p.sequence << "**";
      if (!p.comparison_png.empty()) {
        md << ": ground truth vs. estimate (top view, aligned) and ATE over time, median run of "
              "each configuration\n\n";
        md << "![" << p.sequence << ": trajectories and ATE](" << image_prefix << p.comparison_png
           << ")\n\n";
      } else {
        md << "\n\n";
      }
      if (!p.config_pngs.empty()) {
        md << "Per configuration:";
        bool first = true;
        for (const std::string& config : configs) {
          auto it = p.config_pngs.find(config);
          if (it == p.config_pngs.end() || it->second.empty()) continue;
          md << (first ? " " : " · ") << "[" << ConfigLabel(config) << "](" << image_prefix
             << it->second << ")";
          first = false;
        }
        md << "\n\n";
      }
      if (!p.features_png.empty()) {
        md << p.features_caption << "\n\n";
        md << "![" << p.sequence << ": static and dynamic features](" << image_prefix
           << p.features_png << ")\n\n";
      }
    }
  }
  std::string text = md.str();
  while (text.size() >= 2 && text[text.size() - 1] == '\n' && text[text.size() - 2] == '\n')
    text.pop_back();
  return text;
}

std::string BenchRunsCsv(const std::vector<BenchRun>& runs) {
  std::ostringstream out;
  const auto& columns = CsvColumns();
  for (size_t i = 0; i < columns.size(); ++i) out << (i ? "," : "") << columns[i];
  out << "\n";
  for (const BenchRun& r : runs) {
    for (const std::string* s : {&r.sequence, &r.config, &r.trajectory_path}) {
      if (s->find_first_of(",\n\"") != std::string::npos)
        throw InputError("runs csv: field contains a comma, quote or newline: '" + *s + "'");
    }
    const StageMeans& s = r.stages;
    out << r.sequence << "," << r.config << "," << r.run << "," << r.trajectory_path << ","
        << r.frames << "," << r.poses << "," << r.lost << "," << r.ate_pairs << ","
        << Num(r.ate.rmse) << "," << Num(r.ate.mean) << "," << Num(r.ate.median) << ","
        << Num(r.ate.sd) << "," << Num(r.ate.min) << "," << Num(r.ate.max) << "," << Num(s.orb_ms)
        << "," << Num(s.detection_ms) << "," << Num(s.detection_wait_ms) << ","
        << Num(s.matching_ms) << "," << Num(s.probability_ms) << "," << Num(s.tracking_ms) << ","
        << Num(s.local_mapping_ms) << "," << Num(s.total_ms) << "," << Num(s.median_total_ms) << ","
        << Num(r.loop_seconds) << "," << Num(r.fps) << "," << Num(r.peak_rss_mib) << "\n";
  }
  return out.str();
}

std::vector<BenchRun> ReadBenchRunsCsv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open");
  const auto& columns = CsvColumns();
  std::string line;
  int line_number = 0;
  std::vector<BenchRun> runs;
  auto split = [](const std::string& s) {
    std::vector<std::string> out;
    std::string cur;
    for (char c : s) {
      if (c == ',') {
        out.push_back(cur);
        cur.clear();
      } else if (c != '\r') {
        cur += c;
      }
    }
    out.push_back(cur);
    return out;
  };
  while (std::getline(in, line)) {
    ++line_number;
    if (line.empty()) continue;
    const std::vector<std::string> f = split(line);
    if (line_number == 1) {
      if (f != columns)
        throw InputError(path, 1, "unexpected header (not a dygslam bench runs.csv)");
      continue;
    }
    if (f.size() != columns.size())
      throw InputError(path, line_number,
                       "expected " + std::to_string(columns.size()) + " columns, got " +
                           std::to_string(f.size()));
    size_t k = 0;
    auto number = [&]() {
      const std::string& text = f[k];
      char* end = nullptr;
      const double v = std::strtod(text.c_str(), &end);
      if (text.empty() || *end != '\0')
        throw InputError(path, line_number,
                         "column " + columns[k] + ": not a number: '" + text + "'");
      ++k;
      return v;
    };
    BenchRun r;
    r.sequence = f[k++];
    r.config = f[k++];
    r.run = static_cast<int>(number());
    r.trajectory_path = f[k++];
    r.frames = static_cast<int>(number());
    r.poses = static_cast<int>(number());
    r.lost = static_cast<int>(number());
    r.ate_pairs = static_cast<int>(number());
    r.ate.rmse = number();
    r.ate.mean = number();
    r.ate.median = number();
    r.ate.sd = number();
    r.ate.min = number();
    r.ate.max = number();
    r.stages.orb_ms = number();
    r.stages.detection_ms = number();
    r.stages.detection_wait_ms = number();
    r.stages.matching_ms = number();
    r.stages.probability_ms = number();
    r.stages.tracking_ms = number();
    r.stages.local_mapping_ms = number();
    r.stages.total_ms = number();
    r.stages.median_total_ms = number();
    r.loop_seconds = number();
    r.fps = number();
    r.peak_rss_mib = number();
    runs.push_back(std::move(r));
  }
  if (line_number == 0) throw InputError(path, 0, "empty file");
  return runs;
}

std::string ReplaceBetweenMarkers(const std::string& text, const std::string& content,
                                  const std::string& file_name) {
  const std::string begin = kBenchBeginMarker, end = kBenchEndMarker;
  const size_t b = text.find(begin);
  const size_t e = text.find(end);
  auto line_of = [&](size_t pos) {
    return 1 + static_cast<int>(std::count(text.begin(), text.begin() + pos, '\n'));
  };
  if (b == std::string::npos) throw InputError(file_name, 0, "marker " + begin + " not found");
  if (e == std::string::npos) throw InputError(file_name, 0, "marker " + end + " not found");
  if (text.find(begin, b + 1) != std::string::npos)
    throw InputError(file_name, line_of(text.find(begin, b + 1)), "marker " + begin + " repeated");
  if (text.find(end, e + 1) != std::string::npos)
    throw InputError(file_name, line_of(text.find(end, e + 1)), "marker " + end + " repeated");
  if (e < b) throw InputError(file_name, line_of(e), "marker " + end + " comes before " + begin);
  std::string body = content;
  while (!body.empty() && body.back() == '\n') body.pop_back();
  return text.substr(0, b + begin.size()) + "\n" + body + "\n" + text.substr(e);
}

}  // namespace dygslam
