#include "core/io/detections_io.h"

#include <cmath>
#include <cstdlib>

#include "core/base/error.h"
#include "core/io/file_util.h"

namespace dygslam {
namespace {
double ParseNumber(const std::string& path, int line, const std::string& field, const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end != '\0' || !std::isfinite(v))
    throw InputError(path, line, field + ": not a finite number: '" + Abbreviate(text) + "'");
  return v;
}
}  // namespace

std::map<Timestamp, std::vector<Detection>> ReadDetections(const std::string& path, int num_classes,
                                                           const std::string& classes_source) {
  std::map<Timestamp, std::vector<Detection>> out;
  Timestamp previous;
  bool first = true;
  for (const TextLine& line : ReadDataLines(path)) {
    const auto& t = line.tokens;
    if (t.size() != 7)
      throw InputError(path, line.line_number,
                       "expected 7 columns 'timestamp x y w h class_id score', got " + std::to_string(t.size()));
    const auto stamp = Timestamp::Parse(t[0]);
    if (!stamp)
      throw InputError(path, line.line_number,
                       "timestamp: not a decimal number: '" + Abbreviate(t[0]) + "'");
    if (!first && *stamp < previous)
      throw InputError(path, line.line_number, "timestamp " + t[0] + " goes backwards (previous " + previous.ToString() + ")");
    first = false;
    previous = *stamp;
    Detection d;
    const double x = ParseNumber(path, line.line_number, "x", t[1]);
    const double y = ParseNumber(path, line.line_number, "y", t[2]);
    const double w = ParseNumber(path, line.line_number, "w", t[3]);
    const double h = ParseNumber(path, line.line_number, "h", t[4]);
    const double cls = ParseNumber(path, line.line_number, "class_id", t[5]);
    const double score = ParseNumber(path, line.line_number, "score", t[6]);
    if (w < 0 || h < 0) throw InputError(path, line.line_number, "w/h: negative box size");
    if (cls < 0 || cls != std::floor(cls) || cls > 999999)
      throw InputError(path, line.line_number,
                       "class_id: not an integer in 0..999999: '" + Abbreviate(t[5]) + "'");
    if (num_classes > 0 && cls >= num_classes)
      throw InputError(path, line.line_number,
                       "class_id " + Abbreviate(t[5]) + ": not a class of the detector (0.." +
                           std::to_string(num_classes - 1) +
                           (classes_source.empty() ? std::string() : ", " + classes_source) + ")");
    if (score < 0 || score > 1) throw InputError(path, line.line_number, "score: outside [0, 1]");
    d.box = cv::Rect2f(float(x), float(y), float(w), float(h));
    d.class_id = static_cast<int>(cls);
    d.label = d.class_id == 0 ? "person" : std::to_string(d.class_id);
    d.score = static_cast<float>(score);
    out[*stamp].push_back(d);
  }
  return out;
}

const std::vector<Detection>& DetectionsNear(const std::map<Timestamp, std::vector<Detection>>& all, Timestamp stamp,
                                             double max_difference) {
  static const std::vector<Detection> kNone;
  if (all.empty()) return kNone;
  auto it = all.lower_bound(stamp);
  const std::vector<Detection>* best = nullptr;
  double best_diff = max_difference;
  if (it != all.end() && std::abs(SecondsBetween(stamp, it->first)) <= best_diff) {
    best_diff = std::abs(SecondsBetween(stamp, it->first));
    best = &it->second;
  }
  if (it != all.begin()) {
    --it;
    if (std::abs(SecondsBetween(stamp, it->first)) <= best_diff) best = &it->second;
  }
  return best ? *best : kNone;
}

}  // namespace dygslam
