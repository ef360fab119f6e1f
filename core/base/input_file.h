// Reading a named pipe without hanging: settings files and text lists may be pipes on purpose
// (`--config <(sed ... bonn.yaml)`), but a FIFO that nobody writes into would block the open (and
// the command) forever.
#pragma once

#include <cstddef>
#include <string>

namespace dygslam {

// Seconds ReadPipeBounded waits for the first bytes (or the end) of a pipe.
inline constexpr double kPipeWaitSeconds = 30.0;

// Reads the whole content of the pipe (FIFO) `path`: waits at most `wait_s` for a writer to send
// its first bytes or close it, then reads to the end, at most `max_bytes` (one byte more is
// returned when there is more, so the caller can tell). Throws InputError naming `path` when
// nothing came within `wait_s` ("is its writer running?") or on a read error; `what` names the
// kind of file in the message ("settings file").
std::string ReadPipeBounded(const std::string& path, size_t max_bytes, const std::string& what,
                            double wait_s = kPipeWaitSeconds);

}  // namespace dygslam
