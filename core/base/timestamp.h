// One timestamp type for the whole project: integer nanoseconds since the epoch of the source
// (dataset seconds, DDS builtin time). Parsing from decimal text is exact (no floating point).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace dygslam {

class Timestamp {
 public:
  constexpr Timestamp() = default;
  static constexpr Timestamp FromNanoseconds(int64_t ns) { return Timestamp(ns); }
  static Timestamp FromSeconds(double seconds);
  // Parses "1548339823.898123" (up to 9 decimals; more are rounded away). Returns nullopt on
  // anything that is not a plain non-negative or negative decimal number.
  static std::optional<Timestamp> Parse(std::string_view text);

  constexpr int64_t nanoseconds() const { return ns_; }
  double seconds() const { return static_cast<double>(ns_) * 1e-9; }
  // Decimal seconds: 6 decimals when exact to the microsecond (TUM convention), else 9.
  std::string ToString() const;

  friend constexpr bool operator==(Timestamp a, Timestamp b) { return a.ns_ == b.ns_; }
  friend constexpr bool operator!=(Timestamp a, Timestamp b) { return a.ns_ != b.ns_; }
  friend constexpr bool operator<(Timestamp a, Timestamp b) { return a.ns_ < b.ns_; }
  friend constexpr bool operator<=(Timestamp a, Timestamp b) { return a.ns_ <= b.ns_; }
  friend constexpr bool operator>(Timestamp a, Timestamp b) { return a.ns_ > b.ns_; }
  friend constexpr bool operator>=(Timestamp a, Timestamp b) { return a.ns_ >= b.ns_; }

 private:
  constexpr explicit Timestamp(int64_t ns) : ns_(ns) {}
  int64_t ns_ = 0;
};

// b - a in seconds.
inline double SecondsBetween(Timestamp a, Timestamp b) {
  return static_cast<double>(b.nanoseconds() - a.nanoseconds()) * 1e-9;
}

}  // namespace dygslam
