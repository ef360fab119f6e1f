// Small file helpers shared by the readers and writers: atomic writes and line-oriented text files.
#pragma once

#include <string>
#include <vector>

namespace dygslam {

// Writes `content` to `path` atomically: a temporary file in the same directory, flushed, then
// renamed over `path`. A reader never sees a half-written file. Throws InputError naming the path
// when the directory does not exist or is not writable.
void WriteFileAtomically(const std::string& path, const std::string& content);

// One non-empty, non-comment line of a text file, split on whitespace (and commas).
struct TextLine {
  int line_number = 0;  // 1-based
  std::vector<std::string> tokens;
};

// `text` for a message: at most `max_chars` characters, longer text cut with "... (N bytes)",
// binary bytes escaped (EchoValue, core/base/echo.h).
std::string Abbreviate(const std::string& text, size_t max_chars = 200);

// Reads `path` and returns its data lines: '#' starts a comment (whole line), blank lines are
// skipped, tokens are separated by spaces, tabs or commas; a UTF-8 byte order mark at the start
// is skipped. Throws InputError if the file is missing, unreadable, or a device or socket (a pipe
// is read: its writer must send something within kPipeWaitSeconds, core/base/input_file.h).
std::vector<TextLine> ReadDataLines(const std::string& path);

}  // namespace dygslam
