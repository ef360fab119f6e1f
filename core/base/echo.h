// User-given values inside messages: a settings value, an option's argument or a path can be
// megabytes long or hold binary bytes; a message echoes them bounded and printable.
//
//   throw InputError(path, line, "expected a number, found '" + EchoValue(text) + "'");
#pragma once

#include <cstddef>
#include <string>

namespace dygslam {

// `text` for a message: control characters, DEL and bytes that are not valid UTF-8 escaped as
// \xNN (valid UTF-8 characters kept), cut after `max_chars` characters of the result with
// "... (N bytes)" where N is the size of the whole value.
std::string EchoValue(const std::string& text, size_t max_chars = 200);

// A whole message as printed: every line through EchoValue (binary bytes escaped), at most
// `max_chars` characters in all, so that a value echoed whole somewhere cannot flood stderr.
std::string BoundedMessage(const std::string& message, size_t max_chars = 2000);

// `value` as the shortest text (10 to 17 significant digits) that reads back as exactly `value`:
// for messages that compare two numbers, which must never print alike when they differ in their
// last bits ("0.5 != 0.5").
std::string ExactNumber(double value);

}  // namespace dygslam
