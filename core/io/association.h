// One-to-one association of two sorted timestamp lists by nearest time, the way the TUM RGB-D
// tools (associate.py, evaluate_ate.py) do it: every pair with |a - (b + offset)| < max_difference
// is a candidate; candidates are taken greedily by increasing |difference| (ties: smaller index in
// `a`, then in `b`); each element is used at most once. The result is sorted by index in `a`.
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

#include "core/base/timestamp.h"

namespace dygslam {

struct TimestampMatch {
  size_t first = 0;   // index into a
  size_t second = 0;  // index into b
};

// `a` and `b` must be sorted ascending (throws std::invalid_argument otherwise).
std::vector<TimestampMatch> AssociateTimestamps(const std::vector<Timestamp>& a,
                                                const std::vector<Timestamp>& b,
                                                double max_difference_s, double offset_s = 0.0);

}  // namespace dygslam
