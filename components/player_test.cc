// The player's latency statistics stay bounded in memory over a soak and keep the median and the
// 95th percentile: exact while fewer values than the capacity came in, close after.
#include "components/player.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

namespace dygslam {
namespace {

TEST(LatencyReservoir, ExactBelowCapacity) {
  LatencyReservoir r(4096);
  EXPECT_EQ(r.Quantile(0.5), 0.0);
  std::vector<double> values;
  std::mt19937 rng(3);
  std::lognormal_distribution<double> latency(1.0, 0.5);  // ms, skewed like real latencies
  for (int i = 0; i < 360; ++i) values.push_back(latency(rng));
  for (double v : values) r.Add(v);
  std::sort(values.begin(), values.end());
  EXPECT_EQ(r.count(), 360u);
  EXPECT_EQ(r.Quantile(0.5), values[180]);
  EXPECT_EQ(r.Quantile(0.95), values[342]);  // 360 * 95 / 100
}

TEST(LatencyReservoir, BoundedAndRepresentativeOverALongRun) {
  LatencyReservoir r(4096);
  std::vector<double> values;
  std::mt19937 rng(7);
  std::lognormal_distribution<double> latency(1.0, 0.5);
  // A 30 Hz soak of ~1 h; the latency drifts upward in the second half (what a leak would show).
  for (int i = 0; i < 100000; ++i) values.push_back(latency(rng) + (i >= 50000 ? 1.0 : 0.0));
  for (double v : values) r.Add(v);
  EXPECT_EQ(r.count(), values.size());
  EXPECT_EQ(r.size(), 4096u);
  std::sort(values.begin(), values.end());
  const double median = values[values.size() / 2], p95 = values[values.size() * 95 / 100];
  // A uniform sample of 4096: the rank error of a quantile is ~ sqrt(q(1-q)/n) <= 0.8 %; allow
  // 3 % of rank (about 4 standard deviations) mapped back to values.
  auto rank_of = [&](double v) {
    return static_cast<double>(std::lower_bound(values.begin(), values.end(), v) - values.begin()) /
           values.size();
  };
  EXPECT_NEAR(rank_of(r.Quantile(0.5)), 0.5, 0.03) << "median " << median;
  EXPECT_NEAR(rank_of(r.Quantile(0.95)), 0.95, 0.03) << "p95 " << p95;
}

}  // namespace
}  // namespace dygslam
