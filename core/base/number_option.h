// Numbers given as text on a command line (`--window 4`, `--rate 7.5`): read whole, checked
// against a range, and on failure one clear message that names the option and echoes the value:
//
//   --window: expected an integer in 1..63, got '4x'
//   --rate: expected a number in 0..1e+06, got 'fast'
//
// Every command-line number goes through here: `dygslam` commands through `ArgParser::GetInt` /
// `GetNumber` (apps/command.h, a usage error, exit 2), other executables (dygslam_bench_transport)
// directly.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

namespace dygslam {

// An optional '-' then 1..18 decimal digits, nothing else (no '+', space, exponent or fraction).
std::optional<int64_t> ParseWholeInteger(const std::string& text);
// A finite number written whole as std::stod reads it ("0.5", "1e-3", "-2"); not "1.5x", "",
// "nan", "inf" or a value that overflows a double.
std::optional<double> ParseFiniteNumber(const std::string& text);

// The value of `option` (its name without the dashes) when `text` is an integer / a number in
// [min_value, max_value]; otherwise InvalidOptions("--OPTION: expected an integer in MIN..MAX,
// got 'TEXT'") with TEXT bounded and printable (core/base/echo.h).
int64_t IntegerOption(const std::string& option, const std::string& text, int64_t min_value,
                      int64_t max_value);
double NumberOption(const std::string& option, const std::string& text, double min_value,
                    double max_value);

}  // namespace dygslam
