#include "core/base/child_process.h"

#include <gtest/gtest.h>

#include <csignal>
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

// Programs are found on PATH as a shell would, and run with their arguments whole (no shell in
// between: a quote or a space in an argument is just a character).
TEST(RunProgram, FindsProgramsOnPathAndPassesArgumentsWhole) {
  const std::string sh = FindProgram("sh");
  ASSERT_FALSE(sh.empty());
  EXPECT_EQ(sh.front(), '/');
  EXPECT_EQ(FindProgram("/bin/sh"), "/bin/sh");
  EXPECT_TRUE(FindProgram("dygslam-no-such-program").empty());
  EXPECT_EQ(RunProgram({"sh", "-c", "exit 7"}), 7);
  EXPECT_EQ(RunProgram({"sh", "-c", "test \"$1\" = \"a 'b' \\$c\"", "sh", "a 'b' $c"}), 0);
  EXPECT_EQ(RunProgram({"sh", "-c", "kill -TERM $$"}), 128 + SIGTERM);
  EXPECT_EQ(RunProgram({"dygslam-no-such-program"}), 127);
  EXPECT_EQ(RunProgram({}), 127);
}

}  // namespace
}  // namespace dygslam
