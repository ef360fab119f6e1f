// Small file helpers shared by the readers and writers: atomic writes and line-oriented text files.
#pragma once

#include <string>
#include <vector>

namespace dygslam {

// Writes `content` to `path` atomically: a new temporary file in the same directory (a name with a
// random part, created exclusively, never through a symbolic link), flushed, then renamed over
// `path`. A reader never sees a half-written file. Throws InputError naming the path
// when the directory does not exist or is not writable.
void WriteFileAtomically(const std::string& path, const std::string& content);

// Pins `dir` as an output folder of this process: WriteFileAtomically into it (by this spelling)
// checks that the path still names the folder pinned, so that a folder replaced while the command
// runs (renamed away and a link to another folder put in its place) is never written into. A
// pinned folder that was removed may be made again, empty, under its name (the writes then pin
// the new one). A folder pinned already stays pinned as it was while it exists. Throws
// InputError when `dir` cannot be opened.
void PinOutputFolder(const std::string& dir);
// Pins the folder an output file goes into (PinOutputFolder), when it exists: a command calls it
// for each output file it names (--save-map, a plot) before it starts its work.
void PinFolderOfOutput(const std::string& file);

// Where the folder pinned as `dir` is now: `dir` itself while it still names it (or when `dir` is
// not pinned, or the folder was removed), else the folder's new path (renamed away while the
// command ran; the writes went there).
std::string PinnedFolderNow(const std::string& dir);

// Which version of a file a path names: a file replaced by WriteFileAtomically (a rename) is a new
// inode, so a version taken before a run tells whether the run (or another process of it) wrote
// the file since. `exists` false: nothing at the path.
struct FileVersion {
  bool exists = false;
  unsigned long long device = 0, inode = 0;
  long long mtime_ns = 0, size = 0;
  bool operator==(const FileVersion& o) const {
    return exists == o.exists && device == o.device && inode == o.inode && mtime_ns == o.mtime_ns &&
           size == o.size;
  }
  bool operator!=(const FileVersion& o) const { return !(*this == o); }
};
FileVersion FileVersionOf(const std::string& path);

// A file a command reads or writes, with how the user named it ("--save-map", "GROUNDTRUTH",
// "the dataset's rgb.txt", "OUT/trajectory.txt").
struct NamedPath {
  std::string role;
  std::string path;
};
// Whether `a` and `b` name the same file: the same path once made absolute and resolved (symbolic
// links, "..", a file that does not exist yet), or the same existing file (a hard link).
bool SameFile(const std::string& a, const std::string& b);
// The first clash among the files of a command, "" when there is none: an output that is one of
// the inputs (it would replace the user's file) or another output of the same command (one of
// the two would be lost). The message names both roles and the path.
std::string FindOutputClash(const std::vector<NamedPath>& inputs,
                            const std::vector<NamedPath>& outputs);

// An output replaces an existing file only when that file is of the kind the command writes: it
// starts with `signature` (a map file's "DYGSLMAP", a PNG's header) or is empty. Returns "" when
// `path` may be written, else why not, naming `role` and the path (a user's file given by mistake
// as the output is never replaced).
std::string FindForeignFileAtOutput(const NamedPath& output, const std::string& signature,
                                    const std::string& kind);

// FindOutputClash for many inputs (a dataset's images): each path resolved once, so the cost
// grows with inputs + outputs, not their product. Only output-onto-input clashes.
std::string FindOutputAmongInputs(const std::vector<NamedPath>& inputs,
                                  const std::vector<NamedPath>& outputs);

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
