// dygslam: dispatcher of the command line (subcommands register themselves, see command.h).
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <exception>
#include <iostream>
#include <iterator>
#include <optional>
#include <string>
#include <vector>

#include "apps/command.h"
#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/base/standard_output.h"
#include "core/base/stop_signal.h"

#ifndef DYGSLAM_VERSION
#define DYGSLAM_VERSION "unknown"
#endif

namespace dygslam::cli {
namespace {

// The main commands first, in this order; the others (component, bridge, ...) after them.
const char* const kHelpOrder[] = {"run", "eval", "synth", "map", "bench"};

void PrintHelp(std::ostream& out) {
  out << "dygslam " << DYGSLAM_VERSION
      << " - RGB-D SLAM for dynamic scenes\n\n"
         "usage: dygslam <command> [arguments] [--help]\n\ncommands:\n";
  auto line = [&out](const std::string& name, const std::string& summary) {
    std::string left = "  " + name;
    left.resize(std::max<size_t>(12, left.size() + 2), ' ');
    out << left << summary << "\n";
  };
  for (const char* name : kHelpOrder) {
    if (auto it = Commands().find(name); it != Commands().end()) line(name, it->second.summary);
  }
  line("version", "print the version");
  line("help", "list the commands");
  for (const auto& [name, command] : Commands()) {
    if (std::find(std::begin(kHelpOrder), std::end(kHelpOrder), name) != std::end(kHelpOrder))
      continue;
    line(name, command.summary);
  }
  out << "\nRun 'dygslam <command> --help' for the options of a command.\n"
         "  dygslam run DATASET_DIR [--config FILE] [--filter none|boxes|geometry|paper|full]\n"
         "              [--frames FIRST:LAST] [--out DIR] [--deterministic]\n"
         "              [--processes | --direct] [--no-map] [--detections FILE]\n"
         "  dygslam eval GROUNDTRUTH ESTIMATE [--json] [--plot FILE.png]\n"
         "  dygslam bench DATA_DIR [--runs N] [--quick] [--update-benchmarks BENCHMARKS.md]\n";
}

int Dispatch(const std::vector<std::string>& argv) {
  if (argv.empty()) {
    PrintHelp(std::cerr);
    return 2;
  }
  const std::string& name = argv[0];
  const std::vector<std::string> args(argv.begin() + 1, argv.end());
  if (name == "help" || name == "--help" || name == "-h") {
    if (args.size() > 1) {
      std::cerr << "dygslam help: expected at most one command name (see 'dygslam help')\n";
      return 2;
    }
    if (!args.empty() && Commands().count(args[0])) {
      return Commands().at(args[0]).run({"--help"});
    }
    if (!args.empty() && args[0] != "help" && args[0] != "version") {
      std::cerr << "dygslam help: unknown command '" << EchoValue(args[0])
                << "' (see 'dygslam help')\n";
      return 2;
    }
    PrintHelp(std::cout);
    return 0;
  }
  if (name == "version" || name == "--version") {
    if (!args.empty()) {
      std::cerr << "dygslam version: takes no arguments, got '" << EchoValue(args[0]) << "'\n";
      return 2;
    }
    std::cout << "dygslam " << DYGSLAM_VERSION << "\n";
    return 0;
  }
  auto it = Commands().find(name);
  if (it == Commands().end()) {
    std::cerr << "dygslam: unknown command '" << EchoValue(name) << "' (see 'dygslam help')\n";
    return 2;
  }
  int code = 1;
  try {
    code = it->second.run(args);
  } catch (const StopSignalError& e) {
    // Stopped while waiting on an input (a settings pipe), before any work: nothing to write.
    std::cerr << "dygslam " << name << ": " << BoundedMessage(e.what()) << "\n";
    code = e.exit_code();
  } catch (const InputError& e) {
    std::cerr << "dygslam " << name << ": error: " << BoundedMessage(e.what()) << "\n";
  } catch (const InvalidOptions& e) {
    const std::string message = e.what();
    if (message.rfind("--", 0) == 0 || dynamic_cast<const UsageError*>(&e) != nullptr) {
      // A malformed or out-of-range option value ("--runs: expected ..."), or files of the
      // command line that clash (UsageError): a usage error.
      std::cerr << "dygslam " << name << ": " << BoundedMessage(message) << "\n(dygslam " << name
                << " --help for details)\n";
      code = 2;
    } else {
      std::cerr << "dygslam " << name << ": error: " << BoundedMessage(message) << "\n";
    }
  } catch (const std::exception& e) {
    std::cerr << "dygslam " << name << ": internal error: " << BoundedMessage(e.what()) << "\n";
  }
  // A command that failed before writing anything leaves no empty --out folder behind.
  if (code != 0) RemoveUnusedOutputDirs();
  return code;
}

}  // namespace

// What the command printed must have reached its reader: `dygslam eval --json > /dev/full` (disk
// full, a closed terminal) wrote nothing, so it fails (exit 1, the reason on stderr) instead of
// exiting 0. A reader that closed its pipe on purpose (`dygslam run ... | head`) is not a failure:
// the command's files are written and its exit code stands.
int CheckStandardOutput(const std::string& command, int code) {
  const std::string error = StandardOutputError();
  if (error.empty()) return code;
  const std::string name = command.empty() ? "dygslam" : "dygslam " + command;
  std::fprintf(stderr, "%s: error: cannot write to standard output: %s\n", name.c_str(),
               error.c_str());
  return code == 0 ? 1 : code;
}

}  // namespace dygslam::cli

int main(int argc, char** argv) {
  // Before any thread starts: a stop or a pause reaches the process even when its parent
  // started it with those signals blocked.
  dygslam::UnblockRunSignals();
  // A closed stdout / stderr reader (`dygslam run ... | head`) must not kill the process: writes
  // to the pipe fail with EPIPE and the run finishes with its outputs and exit code.
  std::signal(SIGPIPE, SIG_IGN);
  // Long-running commands catch SIGINT/SIGTERM from the first moment, so a stop request that
  // arrives while they are still setting up ends them cleanly (outputs written), not abruptly.
  std::optional<dygslam::ScopedStopSignals> stop_signals;
  if (argc > 1) {
    const std::string name = argv[1];
    if (name == "run" || name == "map" || name == "component" || name == "bridge" ||
        name == "synth")
      stop_signals.emplace();
  }
  const int code = dygslam::cli::Dispatch(std::vector<std::string>(argv + 1, argv + argc));
  return dygslam::cli::CheckStandardOutput(argc > 1 ? argv[1] : "", code);
}
