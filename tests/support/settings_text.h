// Settings files as text for the bad-input tests (tests/reliability): config/bonn.yaml (without its
// Tracking: section), to append lines to or replace lines of. Header only: DYGSLAM_TEST_SOURCE_DIR
// is the including test's definition (dygslam_add_test).
#pragma once

#include <fstream>
#include <sstream>
#include <string>

namespace dygslam::testing {

// `text` without its section `name`: the "name:" line and the indented lines after it.
inline std::string WithoutSection(const std::string& text, const std::string& name) {
  std::istringstream in(text);
  std::string out, line;
  bool inside = false;
  while (std::getline(in, line)) {
    if (line == name + ":") {
      inside = true;
      continue;
    }
    if (inside && !line.empty() && line[0] == ' ') continue;
    inside = false;
    out += line + "\n";
  }
  return out;
}

// The text of config/bonn.yaml (sensor keys only; a Tracking: section, should one appear, is
// left out so that the cases can append their own).
inline std::string BonnYaml() {
  std::ifstream in(std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml");
  std::stringstream s;
  s << in.rdbuf();
  return WithoutSection(s.str(), "Tracking");
}

// Number of lines of `text` (its '\n' count): the line a line appended after it gets is this + 1.
inline int CountLines(const std::string& text) {
  int n = 0;
  for (char c : text) n += c == '\n';
  return n;
}

}  // namespace dygslam::testing
