// Text of JSON values for the commands' machine-readable outputs (`eval --json`, a run's
// eval.json): strings escaped, numbers printed exactly enough, non-finite numbers as null.
#pragma once

#include <string>

namespace dygslam {

// `text` as a JSON string literal (quotes, backslashes and control characters escaped).
std::string JsonString(const std::string& text);
// `value` with 12 significant digits; NaN and infinities (which JSON has not) as null.
std::string JsonNumber(double value);

}  // namespace dygslam
