// Reading a named pipe without hanging: settings files and text lists may be pipes on purpose
// (`--config <(sed ... bonn.yaml)`), but a FIFO that nobody writes into would block the open (and
// the command) forever.
#pragma once

#include <cstddef>
#include <string>

namespace dygslam {

// Seconds ReadPipeBounded waits for the whole content of a pipe.
inline constexpr double kPipeWaitSeconds = 30.0;

// Reads the whole content of the pipe (FIFO) `path` within `wait_s` in all (a writer that never
// starts, or stalls mid-file, cannot hang the command), at most `max_bytes` (one byte more is
// returned when there is more, so the caller can tell). Throws InputError naming `path` when the
// content did not come within `wait_s` ("is its writer running?" / "is its writer stuck?") or on
// a read error, StopSignalError (core/base/stop_signal.h) when a SIGINT / SIGTERM / SIGHUP
// arrives while it waits (under a ScopedStopSignals); `what` names the kind of file in the
// message ("settings file").
// What `path` is when it exists but is not a regular file, for a message ("not a regular file: a
// FIFO", "... a directory (a link to X)"); "" when it is a regular file or does not exist.
std::string NotRegularFileReason(const std::string& path);

std::string ReadPipeBounded(const std::string& path, size_t max_bytes, const std::string& what,
                            double wait_s = kPipeWaitSeconds);

}  // namespace dygslam
