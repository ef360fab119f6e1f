#include "core/base/json.h"

#include <gtest/gtest.h>

#include <limits>

namespace dygslam {
namespace {

TEST(Json, StringsAreEscaped) {
  EXPECT_EQ(JsonString("plain"), "\"plain\"");
  EXPECT_EQ(JsonString("a\"b\\c"), "\"a\\\"b\\\\c\"");
  EXPECT_EQ(JsonString("line\nnext\ttab"), "\"line\\nnext\\ttab\"");
  EXPECT_EQ(JsonString(std::string("\x01", 1)), "\"\\u0001\"");
}

TEST(Json, NonFiniteNumbersAreNull) {
  EXPECT_EQ(JsonNumber(0.0142), "0.0142");
  EXPECT_EQ(JsonNumber(360), "360");
  EXPECT_EQ(JsonNumber(std::numeric_limits<double>::quiet_NaN()), "null");
  EXPECT_EQ(JsonNumber(std::numeric_limits<double>::infinity()), "null");
  EXPECT_EQ(JsonNumber(1e300), "1e+300");
}

}  // namespace
}  // namespace dygslam
