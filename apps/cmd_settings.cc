// dygslam settings [--markdown]
// Prints every settings key dygslam knows with its default (run/settings_document.h): the
// reference of docs/settings.md, made from the code so that it cannot drift.
#include <iostream>
#include <string>
#include <vector>

#include "apps/command.h"
#include "run/settings_document.h"

namespace dygslam::cli {
namespace {

int RunSettings(const std::vector<std::string>& args) {
  ArgParser p("settings", "[--markdown]",
              R"(Prints every key a settings file may hold, with its default: ORB-SLAM2's camera
and ORB keys and the sections Tracking, LocalMapping, LoopClosing, DynamicFilter,
Detector and OctoMap. "required" marks the keys without a default. The defaults
are read from the options structs the way a run reads a settings file.)");
  p.AddFlag("markdown", "one Markdown table per section (the generated part of docs/settings.md)");
  if (!p.Parse(args)) return p.exit_code();
  std::cout << (p.Flag("markdown") ? SettingsMarkdown() : SettingsText());
  return 0;
}

const CommandRegistrar kRegistrar({"settings", "print the settings keys and their defaults",
                                   RunSettings});

}  // namespace
}  // namespace dygslam::cli
