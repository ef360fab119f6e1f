#include "core/base/timestamp.h"

#include <gtest/gtest.h>

namespace dygslam {
namespace {

TEST(Timestamp, ParsesExactly) {
  auto t = Timestamp::Parse("1548339823.898123");
  ASSERT_TRUE(t.has_value());
  EXPECT_EQ(t->nanoseconds(), 1548339823898123000LL);
  EXPECT_EQ(t->ToString(), "1548339823.898123");
  auto n = Timestamp::Parse("12.123456789");
  ASSERT_TRUE(n.has_value());
  EXPECT_EQ(n->nanoseconds(), 12123456789LL);
  EXPECT_EQ(n->ToString(), "12.123456789");
  EXPECT_EQ(Timestamp::Parse("7")->nanoseconds(), 7000000000LL);
}

TEST(Timestamp, RejectsGarbage) {
  EXPECT_FALSE(Timestamp::Parse("").has_value());
  EXPECT_FALSE(Timestamp::Parse("abc").has_value());
  EXPECT_FALSE(Timestamp::Parse("1.2.3").has_value());
  EXPECT_FALSE(Timestamp::Parse("1e5").has_value());
  EXPECT_FALSE(Timestamp::Parse(".").has_value());
}

TEST(Timestamp, Ordering) {
  auto a = *Timestamp::Parse("1.5");
  auto b = *Timestamp::Parse("1.75");
  EXPECT_LT(a, b);
  EXPECT_DOUBLE_EQ(SecondsBetween(a, b), 0.25);
}

}  // namespace
}  // namespace dygslam
