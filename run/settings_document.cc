#include "run/settings_document.h"

#include <map>
#include <vector>

#include "run/settings_table.h"

namespace dygslam {
namespace {

std::string Section(const std::string& key) {
  const size_t dot = key.find('.');
  return dot == std::string::npos ? "Camera" : key.substr(0, dot);
}

// SettingDocs() grouped by section, sections in the order they first appear.
std::vector<SettingDoc> BySection() {
  std::vector<std::string> sections;
  std::map<std::string, std::vector<SettingDoc>> by_section;
  for (const SettingDoc& d : SettingDocs()) {
    const std::string section = Section(d.key);
    if (!by_section.count(section)) sections.push_back(section);
    by_section[section].push_back(d);
  }
  std::vector<SettingDoc> docs;
  for (const std::string& section : sections)
    for (const SettingDoc& d : by_section[section]) docs.push_back(d);
  return docs;
}

std::string Cell(const std::string& text) {
  std::string cell;
  for (char c : text) cell += c == '|' ? std::string("\\|") : std::string(1, c);
  return cell;
}

}  // namespace

std::string SettingsText() {
  std::string text;
  for (const SettingDoc& d : BySection()) text += d.key + ": " + d.default_value + "\n";
  return text;
}

std::string SettingsMarkdown() {
  std::string text;
  std::string section;
  for (const SettingDoc& d : BySection()) {
    if (Section(d.key) != section) {
      section = Section(d.key);
      text += (text.empty() ? "" : "\n") + std::string("### ") + section + "\n\n";
      text += "| key | default | range | what it does |\n|---|---|---|---|\n";
    }
    const std::string value = d.literal ? "`" + d.default_value + "`" : Cell(d.default_value);
    text += "| `" + d.key + "` | " + value + " | " + Cell(d.range) + " | " + Cell(d.doc) + " |\n";
  }
  text += "\n### Keys no longer read\n\n";
  text +=
      "A file that sets one gets this reason in a warning (an error with --strict-settings).\n\n";
  text += "| key | why |\n|---|---|\n";
  for (const auto& [key, reason] : RetiredSettingsKeys())
    text += "| `" + key + "` | " + reason + " |\n";
  return text;
}

}  // namespace dygslam
