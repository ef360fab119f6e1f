// The defaults of the optional settings keys, as the readers see them: while a
// SettingDefaultsRecorder lives on a thread, every key a ConfigReader looks up with ReadIfPresent
// (or Get) and does not find is recorded with the value its options field keeps, i.e. the default
// of that key. Reading a settings file that holds only the required keys through the readers of a
// run therefore yields every optional key's default from the options structs themselves, so a
// document made from it cannot drift from the code (run/settings_document.h).
#pragma once

#include <map>
#include <string>

namespace dygslam {

class SettingDefaultsRecorder {
 public:
  SettingDefaultsRecorder();
  ~SettingDefaultsRecorder();
  SettingDefaultsRecorder(const SettingDefaultsRecorder&) = delete;
  SettingDefaultsRecorder& operator=(const SettingDefaultsRecorder&) = delete;

  // Fully dotted key -> the field's value when the key was first looked up and absent.
  const std::map<std::string, std::string>& defaults() const { return defaults_; }

  // Called by ConfigReader; records into the thread's current recorder, if any (the first
  // lookup of a key wins).
  static bool Active();
  static void Record(const std::string& full_key, const std::string& value);

 private:
  std::map<std::string, std::string> defaults_;
  SettingDefaultsRecorder* previous_;
};

}  // namespace dygslam
