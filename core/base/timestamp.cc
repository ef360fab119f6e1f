#include "core/base/timestamp.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace dygslam {

Timestamp Timestamp::FromSeconds(double seconds) {
  return Timestamp(static_cast<int64_t>(std::llround(seconds * 1e9)));
}

std::optional<Timestamp> Timestamp::Parse(std::string_view text) {
  size_t i = 0;
  bool negative = false;
  if (i < text.size() && (text[i] == '-' || text[i] == '+')) {
    negative = text[i] == '-';
    ++i;
  }
  int64_t whole = 0;
  size_t whole_digits = 0;
  while (i < text.size() && text[i] >= '0' && text[i] <= '9') {
    whole = whole * 10 + (text[i] - '0');
    // Beyond INT64_MAX nanoseconds (checked every digit, so whole * 10 + 9 never overflows).
    if (whole > 9'223'372'035LL) return std::nullopt;
    ++i;
    ++whole_digits;
  }
  int64_t frac = 0;
  size_t frac_digits = 0;
  bool round_up = false;
  if (i < text.size() && text[i] == '.') {
    ++i;
    while (i < text.size() && text[i] >= '0' && text[i] <= '9') {
      if (frac_digits < 9) {
        frac = frac * 10 + (text[i] - '0');
      } else if (frac_digits == 9) {
        round_up = text[i] >= '5';
      }
      ++frac_digits;
      ++i;
    }
  }
  if (i != text.size() || (whole_digits == 0 && frac_digits == 0)) return std::nullopt;
  for (size_t d = std::min<size_t>(frac_digits, 9); d < 9; ++d) frac *= 10;
  int64_t ns = whole * 1'000'000'000LL + frac + (round_up ? 1 : 0);
  return Timestamp(negative ? -ns : ns);
}

std::string Timestamp::ToString() const {
  const int64_t abs_ns = ns_ < 0 ? -ns_ : ns_;
  const int64_t whole = abs_ns / 1'000'000'000LL;
  const int64_t frac = abs_ns % 1'000'000'000LL;
  char buffer[48];
  if (frac % 1000 == 0) {
    std::snprintf(buffer, sizeof(buffer), "%s%lld.%06lld", ns_ < 0 ? "-" : "",
                  static_cast<long long>(whole), static_cast<long long>(frac / 1000));
  } else {
    std::snprintf(buffer, sizeof(buffer), "%s%lld.%09lld", ns_ < 0 ? "-" : "",
                  static_cast<long long>(whole), static_cast<long long>(frac));
  }
  return buffer;
}

}  // namespace dygslam
