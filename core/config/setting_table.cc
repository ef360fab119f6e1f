#include "core/config/setting_table.h"

#include <charconv>
#include <cmath>

namespace dygslam {
namespace {

// Whole bounds in full ("100000", not "1e+05").
std::string Bound(double v) {
  if (v == std::floor(v) && std::abs(v) < 1e15) return std::to_string(static_cast<long long>(v));
  return FormatSettingValue(v);
}

}  // namespace

bool SettingRange::Contains(double value) const {
  if (!std::isfinite(value)) return false;
  if (zero_too && value == 0) return true;
  if (min_open ? !(value > min) : !(value >= min)) return false;
  if (max_open ? !(value < max) : !(value <= max)) return false;
  if (multiple_of > 0 && std::fmod(value, multiple_of) != 0) return false;
  return true;
}

std::string SettingRange::Text(const std::string& unit) const {
  const std::string u = unit.empty() ? "" : " " + unit;
  const bool has_min = std::isfinite(min), has_max = std::isfinite(max);
  std::string text;
  if (has_min && has_max && !min_open && !max_open) {
    text = Bound(min) + " to " + Bound(max) + u;
  } else if (has_min && has_max) {
    text = (min_open ? "> " : ">= ") + Bound(min) + " and " + (max_open ? "< " : "<= ") +
           Bound(max) + u;
  } else if (has_min) {
    text = (min_open ? "> " : ">= ") + Bound(min) + u;
  } else if (has_max) {
    text = (max_open ? "< " : "<= ") + Bound(max) + u;
  } else {
    text = "any number";
  }
  if (multiple_of > 0) text += ", a multiple of " + std::to_string(multiple_of);
  if (zero_too) text += ", or 0";
  return text;
}

std::string FormatSettingValue(double value) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof(buf), value);
  return std::string(buf, r.ptr);
}

std::string FormatSettingValue(float value) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof(buf), value);
  return std::string(buf, r.ptr);
}

std::string FormatSettingValue(int value) { return std::to_string(value); }

std::string FormatSettingValue(bool value) { return value ? "true" : "false"; }

std::string FormatSettingValue(const std::string& value) { return value; }

std::string FormatSettingValue(const std::vector<std::string>& value) {
  std::string text = "[";
  for (size_t i = 0; i < value.size(); ++i) text += (i == 0 ? "" : ", ") + value[i];
  return text + "]";
}

void FailSettingRange(const ConfigReader& root, const std::string& key, const std::string& value,
                      const SettingRange& range, const std::string& unit, const std::string& doc) {
  root.Fail(key, "value " + value + " is out of range: expected " + range.Text(unit) +
                     (doc.empty() ? "" : " (" + doc + ")"));
}

}  // namespace dygslam
