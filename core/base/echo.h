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

}  // namespace dygslam
