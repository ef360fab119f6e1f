#include "core/base/number_option.h"

#include <gtest/gtest.h>

#include <string>

#include "core/base/error.h"

namespace dygslam {
namespace {

// The message of the InvalidOptions `f` throws ("" when it throws none).
template <typename F>
std::string ErrorOf(F f) {
  try {
    f();
  } catch (const InvalidOptions& e) {
    return e.what();
  }
  return "";
}

TEST(ParseWholeInteger, ReadsSignedDecimalDigitsOnly) {
  EXPECT_EQ(ParseWholeInteger("0"), 0);
  EXPECT_EQ(ParseWholeInteger("42"), 42);
  EXPECT_EQ(ParseWholeInteger("-1"), -1);
  EXPECT_EQ(ParseWholeInteger("999999999999999999"), 999999999999999999);  // 18 digits
  for (const std::string bad : {"", "-", "+3", " 3", "3 ", "1e3", "1.0", "0x10", "4x", "--1",
                                "1000000000000000000" /* 19 digits */}) {
    EXPECT_FALSE(ParseWholeInteger(bad).has_value()) << "'" << bad << "'";
  }
}

TEST(ParseFiniteNumber, ReadsWholeFiniteNumbers) {
  EXPECT_EQ(ParseFiniteNumber("0.5"), 0.5);
  EXPECT_EQ(ParseFiniteNumber("-2"), -2.0);
  EXPECT_EQ(ParseFiniteNumber("1e-3"), 1e-3);
  for (const std::string bad : {"", "1.5x", "fast", "nan", "inf", "-inf", "1e999", "."}) {
    EXPECT_FALSE(ParseFiniteNumber(bad).has_value()) << "'" << bad << "'";
  }
}

TEST(IntegerOption, ReturnsTheValueInRangeAndNamesTheOptionOtherwise) {
  EXPECT_EQ(IntegerOption("window", "1", 1, 63), 1);
  EXPECT_EQ(IntegerOption("window", "63", 1, 63), 63);
  EXPECT_EQ(IntegerOption("domain", "-1", -1, 232), -1);
  EXPECT_EQ(ErrorOf([] { IntegerOption("window", "64", 1, 63); }),
            "--window: expected an integer in 1..63, got '64'");
  EXPECT_EQ(ErrorOf([] { IntegerOption("window", "4x", 1, 63); }),
            "--window: expected an integer in 1..63, got '4x'");
  EXPECT_EQ(ErrorOf([] { IntegerOption("runs", "99999999999999999999", 1, 100); }),
            "--runs: expected an integer in 1..100, got '99999999999999999999'");
}

TEST(NumberOption, ReturnsTheValueInRangeAndNamesTheOptionOtherwise) {
  EXPECT_EQ(NumberOption("rate", "7.5", 0, 1e6), 7.5);
  EXPECT_EQ(NumberOption("rate", "0", 0, 1e6), 0.0);
  EXPECT_EQ(ErrorOf([] { NumberOption("rate", "-0.5", 0, 1e6); }),
            "--rate: expected a number in 0..1e+06, got '-0.5'");
  EXPECT_EQ(ErrorOf([] { NumberOption("rate", "nan", 0, 1e6); }),
            "--rate: expected a number in 0..1e+06, got 'nan'");
}

TEST(NumberOption, EchoesAHugeValueBounded) {
  const std::string huge(100000, '7');
  const std::string message = ErrorOf([&] { NumberOption("loop-minutes", huge + "x", 0, 1e6); });
  EXPECT_LT(message.size(), 400u);
  EXPECT_NE(message.find("(100001 bytes)"), std::string::npos) << message;
}

}  // namespace
}  // namespace dygslam
