// Whether what a command printed reached its reader: a full disk or a closed terminal behind
// stdout is a failure of the command; a reader that closed its pipe on purpose (`... | head`) is
// not.
#pragma once

#include <string>

namespace dygslam {

// Flushes stdout (and std::cout): "" when everything printed so far was written, or when the
// reader closed its pipe (EPIPE, a FIFO); else the reason ("No space left on device").
std::string StandardOutputError();

}  // namespace dygslam
