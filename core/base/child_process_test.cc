#include "core/base/child_process.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

namespace dygslam {
namespace {

// What /bin/sh makes of `word` as one argument of printf.
std::string ThroughShell(const std::string& word) {
  const std::string command = "printf %s " + ShellQuote(word);
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return "<popen failed>";
  std::string out;
  char buffer[256];
  size_t n = 0;
  while ((n = std::fread(buffer, 1, sizeof(buffer), pipe)) > 0) out.append(buffer, n);
  ::pclose(pipe);
  return out;
}

TEST(ShellQuote, SafeWordsStayAndEveryOtherWordReachesTheProgramWhole) {
  EXPECT_EQ(ShellQuote("out/run_1.txt"), "out/run_1.txt");
  EXPECT_EQ(ShellQuote(""), "''");
  EXPECT_EQ(ShellQuote("a b"), "'a b'");
  for (const std::string word : {"a b", "it's", "$HOME", "`id`", "a;b|c", "'", "\"x\"", "*"})
    EXPECT_EQ(ThroughShell(word), word) << ShellQuote(word);
}

}  // namespace
}  // namespace dygslam
