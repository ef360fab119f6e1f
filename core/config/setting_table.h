// Settings tables: each key of a settings file written once, with the options field it sets, the
// values it accepts, its unit and one line on what it does. A table drives reading (ReadSettings
// of the table), the range checks (an error naming the file, line and key, the range and the
// doc), the known-key list and the generated settings document (`dygslam settings`).
//
//   const SettingsTable<OctoMapOptions>& Table() {
//     static const SettingsTable<OctoMapOptions> table = {
//         {{"OctoMap.resolution", DYGSLAM_SETTING_FIELD(resolution),
//           SettingRange::AboveAtMost(0.001, 10), "m", "leaf size"},
//          ...},
//         {{"OctoMap.min_range", "below OctoMap.max_range",
//           [](const OctoMapOptions& o) { return o.min_range < o.max_range; }}}};
//     return table;
//   }
//   table.Read(reader, &options);
//
// A key whose reading is more than "value into field" (a model name that fills several fields, a
// path relative to the settings file) has a row with its own read function; it is still one row.
#pragma once

#include <functional>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/config/config_reader.h"

// A row's field: `options.member` (nested members too: `detector.input_width`).
#define DYGSLAM_SETTING_FIELD(member) \
  [](auto& o) -> auto& { return o.member; }

namespace dygslam {

// The numbers a key accepts: from min to max, either end open or closed; `zero_too` also accepts
// 0 (a "same as" / "off" value); `multiple_of` > 0 asks integers to be its multiples.
struct SettingRange {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_open = false;
  bool max_open = false;
  bool zero_too = false;
  int multiple_of = 0;

  static SettingRange Any() { return {}; }
  static SettingRange Closed(double lo, double hi) { return {lo, hi, false, false}; }
  static SettingRange Open(double lo, double hi) { return {lo, hi, true, true}; }
  static SettingRange Above(double lo) { return {lo, Any().max, true, false}; }
  static SettingRange AtLeast(double lo) { return {lo, Any().max, false, false}; }
  static SettingRange AtMost(double hi) { return {Any().min, hi, false, false}; }
  static SettingRange AboveAtMost(double lo, double hi) { return {lo, hi, true, false}; }
  SettingRange OrZero() const {
    SettingRange r = *this;
    r.zero_too = true;
    return r;
  }
  SettingRange MultipleOf(int step) const {
    SettingRange r = *this;
    r.multiple_of = step;
    return r;
  }

  bool Contains(double value) const;
  // "> 0 and <= 100000", "0 to 1", "any number"; `unit` follows the bounds ("px", "m", "").
  std::string Text(const std::string& unit) const;
};

// What `dygslam settings` and docs/settings.md show of one key.
struct SettingDoc {
  std::string key;            // fully dotted ("Camera.fx"); "Viewer.*" for a whole section
  std::string default_value;  // as a settings file writes it, or a description (literal false)
  bool literal = true;
  bool required = false;
  std::string range;  // "" for a key that is not a number
  std::string doc;
};

// A number, a bool, a text as a settings file writes it (shortest round-trip numbers).
std::string FormatSettingValue(double value);
std::string FormatSettingValue(float value);
std::string FormatSettingValue(int value);
std::string FormatSettingValue(bool value);
std::string FormatSettingValue(const std::string& value);
std::string FormatSettingValue(const std::vector<std::string>& value);

// Throws the range error of `key`: "<file>:<line>: key 'K': value V is out of range: expected
// RANGE (DOC)".
[[noreturn]] void FailSettingRange(const ConfigReader& root, const std::string& key,
                                   const std::string& value, const SettingRange& range,
                                   const std::string& unit, const std::string& doc);

template <typename Options>
class SettingRow {
 public:
  using ReadFunction = std::function<void(const ConfigReader& root, Options* options)>;

  // A key read into a field. Numbers outside `range` are errors.
  template <typename Field>
  SettingRow(std::string key, Field field, SettingRange range, std::string unit, std::string doc)
      : key_(std::move(key)), range_(range), unit_(std::move(unit)), doc_(std::move(doc)) {
    using T = std::remove_reference_t<decltype(field(std::declval<Options&>()))>;
    constexpr bool kNumber = std::is_arithmetic_v<T> && !std::is_same_v<T, bool>;
    numeric_ = kNumber;
    read_field_ = [field](const SettingRow& row, const ConfigReader& root, Options* options) {
      T& value = field(*options);
      if (row.required_) {
        value = root.Require<T>(row.key_);
      } else if (!root.ReadIfPresent(row.key_, &value)) {
        return;
      }
      if constexpr (kNumber) {
        if (!row.range_.Contains(static_cast<double>(value)))
          FailSettingRange(root, row.key_, FormatSettingValue(value), row.range_, row.unit_,
                           row.doc_);
      }
    };
    format_ = [field](const Options& options) {
      return FormatSettingValue(field(options));
    };
  }
  // A key with its own read function (it reads `key` from the root reader itself).
  SettingRow(std::string key, ReadFunction read, std::string default_text, std::string doc)
      : key_(std::move(key)),
        doc_(std::move(doc)),
        default_text_(std::move(default_text)),
        read_(std::move(read)) {}

  // The key must be in the file.
  SettingRow Required() const {
    SettingRow r = *this;
    r.required_ = true;
    return r;
  }
  // The default is not the field's plain value ("Camera.fps": derived from another key).
  SettingRow DefaultText(std::string text) const {
    SettingRow r = *this;
    r.default_text_ = std::move(text);
    return r;
  }

  const std::string& key() const { return key_; }
  // A number with a range (false for bools, texts and rows with their own read function).
  bool numeric() const { return numeric_; }
  const SettingRange& range() const { return range_; }
  void Read(const ConfigReader& root, Options* options) const {
    if (read_field_) {
      read_field_(*this, root, options);
    } else {
      read_(root, options);
    }
  }
  // The field's value in `options` as a file writes it ("" for a row with its own read function).
  std::string Value(const Options& options) const { return format_ ? format_(options) : ""; }
  // `defaults`: the options a file without this key leaves.
  SettingDoc Doc(const Options& defaults) const {
    SettingDoc d;
    d.key = key_;
    d.required = required_;
    d.doc = doc_;
    d.range = numeric_ ? range_.Text(unit_) : "";
    if (required_) {
      d.default_value = "required";
      d.literal = false;
    } else if (!default_text_.empty() || !format_) {
      d.default_value = default_text_;
      d.literal = false;
    } else {
      d.default_value = format_(defaults);
    }
    return d;
  }

 private:
  std::string key_;
  SettingRange range_;
  std::string unit_;
  std::string doc_;
  std::string default_text_;
  bool required_ = false;
  bool numeric_ = false;
  std::function<void(const SettingRow&, const ConfigReader&, Options*)> read_field_;
  ReadFunction read_;
  std::function<std::string(const Options&)> format_;
};

// A condition between keys (OctoMap.min_range below OctoMap.max_range), checked after the rows:
// when it fails, the error names `key`, its value and `expected`.
template <typename Options>
struct SettingRelation {
  std::string key;
  std::string expected;
  std::function<bool(const Options&)> holds;
};

template <typename Options>
struct SettingsTable {
  std::vector<SettingRow<Options>> rows;
  std::vector<SettingRelation<Options>> relations;

  // Reads every row's key that is in the file (in table order) and checks the relations. A section
  // of the rows given as a list or a single value is an error naming its line.
  void Read(const ConfigReader& root, Options* options) const {
    for (const SettingRow<Options>& row : rows) {
      const size_t dot = row.key().find('.');
      if (dot != std::string::npos) root.Section(row.key().substr(0, dot));
    }
    for (const SettingRow<Options>& row : rows) row.Read(root, options);
    for (const SettingRelation<Options>& relation : relations) {
      if (relation.holds(*options)) continue;
      std::string value;
      for (const SettingRow<Options>& row : rows)
        if (row.key() == relation.key) value = row.Value(*options);
      root.Fail(relation.key, "value " + value + " is out of range: expected " + relation.expected);
    }
  }
  std::vector<std::string> Keys() const {
    std::vector<std::string> keys;
    for (const SettingRow<Options>& row : rows) keys.push_back(row.key());
    return keys;
  }
  std::vector<SettingDoc> Docs(const Options& defaults) const {
    std::vector<SettingDoc> docs;
    for (const SettingRow<Options>& row : rows) docs.push_back(row.Doc(defaults));
    return docs;
  }
};

}  // namespace dygslam
