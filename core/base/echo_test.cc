#include "core/base/echo.h"

#include <gtest/gtest.h>

#include <string>

namespace dygslam {
namespace {

TEST(EchoValue, ShortPrintableTextIsUnchanged) {
  EXPECT_EQ(EchoValue("yolo-fastest-1.1"), "yolo-fastest-1.1");
  EXPECT_EQ(EchoValue(""), "");
  EXPECT_EQ(EchoValue("caf\xC3\xA9 \xE2\x82\xAC"), "caf\xC3\xA9 \xE2\x82\xAC");  // UTF-8 kept
}

TEST(EchoValue, LongValueIsCutAndSaysItsSize) {
  const std::string value(50 << 20, 'a');
  const std::string echoed = EchoValue(value);
  EXPECT_EQ(echoed, std::string(200, 'a') + "... (52428800 bytes)");
  EXPECT_EQ(EchoValue(std::string(201, 'b'), 200).size(),
            200u + std::string("... (201 bytes)").size());
  EXPECT_EQ(EchoValue(std::string(200, 'b'), 200), std::string(200, 'b'));
}

TEST(EchoValue, BinaryBytesAreEscaped) {
  EXPECT_EQ(EchoValue(std::string("a\0b", 3)), "a\\x00b");
  EXPECT_EQ(EchoValue("x\ny\x1b[31m"), "x\\x0ay\\x1b[31m");
  EXPECT_EQ(EchoValue("\xff\xfe"), "\\xff\\xfe");
  EXPECT_EQ(EchoValue("\xC3"), "\\xc3");                    // a cut UTF-8 sequence
  EXPECT_EQ(EchoValue("\xED\xA0\x80"), "\\xed\\xa0\\x80");  // a UTF-16 surrogate
  // The cut counts escaped characters: the message stays bounded for any input.
  const std::string binary(1000, '\x01');
  EXPECT_EQ(EchoValue(binary, 10),
            "\\x01\\x01\\x01\\x01\\x01\\x01\\x01\\x01\\x01\\x01... (1000 bytes)");
}

}  // namespace
}  // namespace dygslam
