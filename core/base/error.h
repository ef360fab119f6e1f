// Errors that name what is wrong: the file, the line, the key.
#pragma once

#include <stdexcept>
#include <string>

namespace dygslam {

// Bad input from the outside world (files, settings, samples). The message names the source.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& message) : std::runtime_error(message) {}
  // "<file>:<line>: <message>" (line omitted when <= 0).
  InputError(const std::string& file, int line, const std::string& message)
      : std::runtime_error(Format(file, line, message)) {}

  static std::string Format(const std::string& file, int line, const std::string& message) {
    if (line > 0) return file + ":" + std::to_string(line) + ": " + message;
    return file + ": " + message;
  }
};

// An options struct failed its Check(): the message names the field.
class InvalidOptions : public std::invalid_argument {
 public:
  explicit InvalidOptions(const std::string& message) : std::invalid_argument(message) {}
};

// A command line that cannot run as given (two of its files clash, options that exclude each
// other): the command reports it as a usage error (exit 2), with its usage line.
class UsageError : public InvalidOptions {
 public:
  explicit UsageError(const std::string& message) : InvalidOptions(message) {}
};

#define DYGSLAM_CHECK_OPTION(cond, name)                                        \
  do {                                                                          \
    if (!(cond))                                                                \
      throw ::dygslam::InvalidOptions(std::string("invalid option ") + (name) + \
                                      ": requires " #cond);                     \
  } while (0)

}  // namespace dygslam
