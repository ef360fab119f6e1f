#include "core/base/number_option.h"

#include <cmath>
#include <exception>
#include <sstream>

#include "core/base/echo.h"
#include "core/base/error.h"

namespace dygslam {

std::optional<int64_t> ParseWholeInteger(const std::string& text) {
  const bool negative = !text.empty() && text[0] == '-';
  const size_t first = negative ? 1 : 0;
  const size_t num_digits = text.size() - first;
  if (num_digits == 0 || num_digits > 18) return std::nullopt;  // 18 digits cannot overflow
  int64_t value = 0;
  for (size_t i = first; i < text.size(); ++i) {
    if (text[i] < '0' || text[i] > '9') return std::nullopt;
    value = value * 10 + (text[i] - '0');
  }
  return negative ? -value : value;
}

std::optional<double> ParseFiniteNumber(const std::string& text) {
  size_t used = 0;
  double value = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {  // no number, or out of a double's range
    return std::nullopt;
  }
  if (used != text.size() || !std::isfinite(value)) return std::nullopt;
  return value;
}

int64_t IntegerOption(const std::string& option, const std::string& text, int64_t min_value,
                      int64_t max_value) {
  const std::optional<int64_t> value = ParseWholeInteger(text);
  if (value && *value >= min_value && *value <= max_value) return *value;
  throw InvalidOptions("--" + option + ": expected an integer in " + std::to_string(min_value) +
                       ".." + std::to_string(max_value) + ", got '" + EchoValue(text) + "'");
}

double NumberOption(const std::string& option, const std::string& text, double min_value,
                    double max_value) {
  const std::optional<double> value = ParseFiniteNumber(text);
  if (value && *value >= min_value && *value <= max_value) return *value;
  std::ostringstream message;
  message << "--" << option << ": expected a number in " << min_value << ".." << max_value
          << ", got '" << EchoValue(text) << "'";
  throw InvalidOptions(message.str());
}

}  // namespace dygslam
