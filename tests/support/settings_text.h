// Settings files as text for the bad-input tests (tests/reliability): config/bonn.yaml as it is,
// to append lines to or replace lines of. Header only: DYGSLAM_TEST_SOURCE_DIR is the including
// test's definition (dygslam_add_test).
#pragma once

#include <fstream>
#include <sstream>
#include <string>

namespace dygslam::testing {

// The text of config/bonn.yaml.
inline std::string BonnYaml() {
  std::ifstream in(std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml");
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Number of lines of `text` (its '\n' count): the line a line appended after it gets is this + 1.
inline int CountLines(const std::string& text) {
  int n = 0;
  for (char c : text) n += c == '\n';
  return n;
}

}  // namespace dygslam::testing
