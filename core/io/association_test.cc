#include "core/io/association.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <random>
#include <set>

namespace dygslam {
namespace {

std::vector<Timestamp> Stamps(std::initializer_list<int64_t> ms) {
  std::vector<Timestamp> out;
  for (int64_t v : ms) out.push_back(Timestamp::FromNanoseconds(v * 1'000'000));
  return out;
}

TEST(Association, GreedyPrefersSmallestDifferenceOverNearestPerElement) {
  // a0 is 12 ms from b0, a1 only 2 ms: b0 goes to a1, a0 stays unmatched.
  const auto m = AssociateTimestamps(Stamps({0, 10}), Stamps({12}), 0.02);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].first, 1u);
  EXPECT_EQ(m[0].second, 0u);
}

TEST(Association, RespectsMaxDifferenceStrictly) {
  EXPECT_TRUE(AssociateTimestamps(Stamps({0}), Stamps({20}), 0.02).empty());
  EXPECT_EQ(AssociateTimestamps(Stamps({0}), Stamps({19}), 0.02).size(), 1u);
  EXPECT_EQ(AssociateTimestamps(Stamps({0}), Stamps({-19}), 0.02).size(), 1u);
}

TEST(Association, OffsetShiftsSecondList) {
  const auto m = AssociateTimestamps(Stamps({100, 200}), Stamps({0, 100}), 0.02, 0.1);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0].second, 0u);
  EXPECT_EQ(m[1].second, 1u);
}

TEST(Association, RejectsUnsortedInput) {
  EXPECT_THROW(AssociateTimestamps(Stamps({10, 0}), Stamps({0}), 0.02), std::invalid_argument);
}

// Independent brute force: repeatedly take the globally closest unused pair.
std::vector<std::pair<size_t, size_t>> BruteForce(const std::vector<Timestamp>& a,
                                                  const std::vector<Timestamp>& b, int64_t max_ns) {
  std::vector<bool> ua(a.size()), ub(b.size());
  std::vector<std::pair<size_t, size_t>> out;
  while (true) {
    int64_t best = max_ns;
    size_t bi = 0, bj = 0;
    bool found = false;
    for (size_t i = 0; i < a.size(); ++i) {
      if (ua[i]) continue;
      for (size_t j = 0; j < b.size(); ++j) {
        if (ub[j]) continue;
        const int64_t d = std::llabs(a[i].nanoseconds() - b[j].nanoseconds());
        if (d < best) {
          best = d;
          bi = i;
          bj = j;
          found = true;
        }
      }
    }
    if (!found) break;
    ua[bi] = ub[bj] = true;
    out.emplace_back(bi, bj);
  }
  std::sort(out.begin(), out.end());
  return out;
}

TEST(Association, MatchesBruteForceOnRandomStreams) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 50; ++trial) {
    std::uniform_int_distribution<int64_t> step(5'000'000, 45'000'000);  // 5..45 ms
    std::vector<Timestamp> a, b;
    int64_t ta = 1'000'000'000, tb = 1'000'000'000 + step(rng) / 3;
    for (int i = 0; i < 60; ++i) {
      a.push_back(Timestamp::FromNanoseconds(ta += step(rng)));
      b.push_back(Timestamp::FromNanoseconds(tb += step(rng)));
    }
    const auto m = AssociateTimestamps(a, b, 0.02);
    const auto ref = BruteForce(a, b, 20'000'000);
    ASSERT_EQ(m.size(), ref.size()) << "trial " << trial;
    std::set<size_t> used_b;
    for (size_t k = 0; k < m.size(); ++k) {
      EXPECT_EQ(m[k].first, ref[k].first);
      EXPECT_EQ(m[k].second, ref[k].second);
      EXPECT_TRUE(used_b.insert(m[k].second).second);
    }
  }
}

}  // namespace
}  // namespace dygslam
