// Settings files: ORB-SLAM2 / OpenCV-FileStorage style YAML read through yaml-cpp.
//
//   ConfigReader reader = ConfigReader::FromFile("config/tum1.yaml");
//   double fx = reader.Require<double>("Camera.fx");          // required key
//   int n = reader.Get<int>("ORBextractor.nFeatures", 1000);  // optional key with default
//
// A leading "%YAML:1.0" line is ignored and "!!opencv-matrix" tags are accepted. A dotted key
// "Camera.fx" is found both as a flat key (`Camera.fx: 517.3`) and as a nested one
// (`Camera: {fx: 517.3}`); a key given both ways (or twice) is an error naming both lines.
//
// Module sections (core/config/<module>_config.cc):
//   void ReadOptions(const ConfigReader& root, DynamicFilterOptions* options) {
//     const ConfigReader s = root.Section("DynamicFilter");   // "DynamicFilter.x" or nested
//     s.ReadIfPresent("probabilityThreshold", &options->probability_threshold);
//     s.CheckOptions(*options);  // InvalidOptions -> InputError "file:line: ... key ..."
//   }
//
// Supported T: double, float, int, int64_t, bool, std::string, std::vector<std::string>,
// std::vector<double> (a sequence or an !!opencv-matrix's data), std::vector<int>.
// Numbers must be finite; ints must be integral and in range; bools are
// true/false/yes/no/on/off/1/0. Every error is a dygslam::InputError naming "file:line" and the
// full key. A file whose aliases refer to their own ancestors ("recursive alias"), nested deeper
// than 32 levels or with more than 200,000 values (aliases expanded) is rejected when loaded, so
// every later walk of the tree is bounded.
#pragma once

#include <memory>
#include <set>
#include <string>
#include <vector>

#include "core/base/error.h"

namespace dygslam {

class ConfigReader {
 public:
  // An empty reader (no keys); path() is "".
  ConfigReader();
  // Throws InputError for a missing/unreadable file or malformed YAML (with the line).
  static ConfigReader FromFile(const std::string& path);
  // `name` stands in for the file name in messages.
  static ConfigReader FromString(const std::string& text, const std::string& name = "<string>");

  const std::string& path() const;
  // "" for the root reader, "DynamicFilter" for Section("DynamicFilter").
  const std::string& prefix() const { return prefix_; }
  // A view of the keys below `name` (nested map or flat "name.key" entries). Sections nest.
  // InputError when `name` is given as a list or a single value instead of a map.
  ConfigReader Section(const std::string& name) const;

  bool Has(const std::string& key) const;
  // Value of an optional key; `default_value` if absent or empty (`key:` without a value).
  template <typename T>
  T Get(const std::string& key, const T& default_value) const;
  // Value of a required key; InputError naming the key if absent or empty.
  template <typename T>
  T Require(const std::string& key) const;
  // Sets *value and returns true if the key is present; leaves *value unchanged otherwise.
  template <typename T>
  bool ReadIfPresent(const std::string& key, T* value) const;

  // 1-based line of `key` in the file, 0 if absent.
  int LineOf(const std::string& key) const;
  // All leaf keys below this reader, fully dotted ("Camera.fx"), in file order.
  std::vector<std::string> Keys() const;

  // A key of the file that no module reads: its line and the closest known key ("" when no
  // known key is within a few edits).
  struct UnknownKey {
    std::string key;  // fully dotted
    int line = 0;
    std::string closest;
  };
  // The keys below this reader that are not in `known` (fully dotted keys; "Viewer.*" accepts
  // every key below Viewer), in file order.
  std::vector<UnknownKey> UnknownKeys(const std::vector<std::string>& known) const;
  // "<file>:<line>: unknown key 'Camera.fxx' (did you mean 'Camera.fx'?)".
  std::string UnknownKeyMessage(const UnknownKey& unknown) const;

  // Throws InputError "<file>:<line>: key '<prefix.key>': <message>".
  [[noreturn]] void Fail(const std::string& key, const std::string& message) const;

  // Runs options.Check() and turns an InvalidOptions into an InputError that names this file,
  // the line of the offending key (when the option name is a key of the file) and the key.
  template <typename Options>
  void CheckOptions(const Options& options) const {
    try {
      options.Check();
    } catch (const InvalidOptions& e) {
      FailInvalidOptions(e);
    }
  }

 private:
  struct Impl;
  ConfigReader(std::shared_ptr<const Impl> impl, std::string prefix);
  std::string FullKey(const std::string& key) const;
  [[noreturn]] void FailInvalidOptions(const InvalidOptions& e) const;

  std::shared_ptr<const Impl> impl_;
  std::string prefix_;
};

// Testing aid: while a KeyLookupRecorder lives on a thread, every key that thread reads through a
// ConfigReader (Has, Get, Require, ReadIfPresent; fully dotted) is recorded, present in the file or
// not. Lets a test check that every key some module reads is in KnownSettingsKeys() (otherwise a
// key that works would be warned about as unknown). Recorders nest (the innermost records).
class KeyLookupRecorder {
 public:
  KeyLookupRecorder();
  ~KeyLookupRecorder();
  KeyLookupRecorder(const KeyLookupRecorder&) = delete;
  KeyLookupRecorder& operator=(const KeyLookupRecorder&) = delete;
  const std::set<std::string>& keys() const { return keys_; }
  // Called by ConfigReader; records into the thread's current recorder, if any.
  static void Record(const std::string& full_key);

 private:
  std::set<std::string> keys_;
  KeyLookupRecorder* previous_;
};

}  // namespace dygslam
