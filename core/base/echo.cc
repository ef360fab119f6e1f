#include "core/base/echo.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

namespace dygslam {
namespace {

// Length of the valid UTF-8 sequence starting at text[i] (2..4), 0 when it is not one.
size_t Utf8SequenceLength(const std::string& text, size_t i) {
  const auto byte = [&](size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char first = byte(i);
  size_t length = 0;
  if (first >= 0xC2 && first <= 0xDF) {
    length = 2;
  } else if (first >= 0xE0 && first <= 0xEF) {
    length = 3;
  } else if (first >= 0xF0 && first <= 0xF4) {
    length = 4;
  } else {
    return 0;
  }
  if (i + length > text.size()) return 0;
  for (size_t k = 1; k < length; ++k) {
    if ((byte(i + k) & 0xC0) != 0x80) return 0;
  }
  // Overlong 3/4-byte forms, UTF-16 surrogates and code points above U+10FFFF.
  if (first == 0xE0 && byte(i + 1) < 0xA0) return 0;
  if (first == 0xED && byte(i + 1) > 0x9F) return 0;
  if (first == 0xF0 && byte(i + 1) < 0x90) return 0;
  if (first == 0xF4 && byte(i + 1) > 0x8F) return 0;
  return length;
}

}  // namespace

std::string EchoValue(const std::string& text, size_t max_chars) {
  std::string out;
  size_t chars = 0, i = 0;
  while (i < text.size() && chars < max_chars) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c >= 0x20 && c < 0x7F) {
      out += text[i++];
    } else if (const size_t n = c >= 0x80 ? Utf8SequenceLength(text, i) : 0; n > 0) {
      out.append(text, i, n);
      i += n;
    } else {
      char escaped[8];
      std::snprintf(escaped, sizeof(escaped), "\\x%02x", c);
      out += escaped;
      ++i;
    }
    ++chars;
  }
  if (i < text.size()) out += "... (" + std::to_string(text.size()) + " bytes)";
  return out;
}

std::string BoundedMessage(const std::string& message, size_t max_chars) {
  // Every line escaped (EchoValue), not cut yet.
  std::string whole;
  for (size_t start = 0; start <= message.size();) {
    const size_t end = std::min(message.find('\n', start), message.size());
    if (start > 0) whole += '\n';
    whole += EchoValue(message.substr(start, end - start), std::string::npos);
    start = end + 1;
  }
  if (whole.size() <= max_chars) return whole;
  // Too long: its start (what the message is about) and its end (the reason, which follows the
  // long value: "PATH: is not writable") are kept, the middle is cut.
  const std::string cut = " ... (" + std::to_string(message.size()) + "-byte message, cut) ... ";
  const size_t keep = max_chars > cut.size() + 2 ? (max_chars - cut.size()) / 2 : 1;
  size_t head_end = keep;
  while (head_end > 0 && (static_cast<unsigned char>(whole[head_end]) & 0xC0) == 0x80) --head_end;
  size_t tail_start = whole.size() - keep;
  while (tail_start < whole.size() &&
         (static_cast<unsigned char>(whole[tail_start]) & 0xC0) == 0x80)
    ++tail_start;
  return whole.substr(0, head_end) + cut + whole.substr(tail_start);
}

std::string ExactNumber(double value) {
  std::string text;
  for (int precision = 10; precision <= 17; ++precision) {
    std::ostringstream out;
    out.precision(precision);
    out << value;
    text = out.str();
    if (!std::isfinite(value) || std::strtod(text.c_str(), nullptr) == value) break;
  }
  return text;
}

}  // namespace dygslam
