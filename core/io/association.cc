#include "core/io/association.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <tuple>

namespace dygslam {

std::vector<TimestampMatch> AssociateTimestamps(const std::vector<Timestamp>& a,
                                                const std::vector<Timestamp>& b,
                                                double max_difference_s, double offset_s) {
  if (!std::is_sorted(a.begin(), a.end()) || !std::is_sorted(b.begin(), b.end())) {
    throw std::invalid_argument("AssociateTimestamps: inputs must be sorted");
  }
  const int64_t max_ns = static_cast<int64_t>(std::llround(max_difference_s * 1e9));
  const int64_t offset_ns = static_cast<int64_t>(std::llround(offset_s * 1e9));
  // Candidates: (|diff|, i, j). Both lists are sorted, so the b-window of each a slides.
  std::vector<std::tuple<int64_t, size_t, size_t>> candidates;
  size_t lo = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    const int64_t ta = a[i].nanoseconds();
    while (lo < b.size() && b[lo].nanoseconds() + offset_ns <= ta - max_ns) ++lo;
    for (size_t j = lo; j < b.size(); ++j) {
      const int64_t diff = ta - (b[j].nanoseconds() + offset_ns);
      if (diff <= -max_ns) break;
      candidates.emplace_back(diff < 0 ? -diff : diff, i, j);
    }
  }
  std::sort(candidates.begin(), candidates.end());
  std::vector<bool> used_a(a.size(), false), used_b(b.size(), false);
  std::vector<TimestampMatch> matches;
  for (const auto& [diff, i, j] : candidates) {
    if (used_a[i] || used_b[j]) continue;
    used_a[i] = used_b[j] = true;
    matches.push_back({i, j});
  }
  std::sort(matches.begin(), matches.end(),
            [](const TimestampMatch& x, const TimestampMatch& y) { return x.first < y.first; });
  return matches;
}

}  // namespace dygslam
