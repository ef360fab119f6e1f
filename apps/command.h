// The `dygslam` command line: one executable, one file per subcommand.
//
// A subcommand lives in apps/cmd_<name>.cc and registers itself:
//
//   namespace dygslam::cli {
//   namespace {
//   int RunEval(const std::vector<std::string>& args) {
//     ArgParser p("eval", "GROUNDTRUTH ESTIMATE [--json] [--plot FILE.png]", "Prints ATE / RPE.");
//     p.AddFlag("json", "print one JSON object");
//     p.AddOption("plot", "FILE.png", "draw trajectories and ATE over time");
//     if (!p.Parse(args)) return p.exit_code();   // --help (0) or a usage error (2)
//     ...
//     return 0;
//   }
//   const CommandRegistrar kRegistrar({"eval", "evaluate a trajectory (ATE/RPE)", RunEval});
//   }  // namespace
//   }  // namespace dygslam::cli
//
// apps/CMakeLists.txt globs cmd_*.cc into the executable. The dispatcher (dygslam.cc) catches
// InputError / InvalidOptions (exit 1, message names the file/line/key); an unknown command is a
// usage error (exit 2).
// Exit codes: 0 success, 1 bad input or runtime failure, 2 usage error / unavailable command,
// 3 a run that ended with fewer frames than requested without being asked to (kExitIncompleteRun).
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/config/settings.h"
#include "core/io/dataset.h"
#include "core/io/file_util.h"
#include "run/run_files.h"
#include "run/run_outputs.h"
#include "run/run_settings.h"
#include "run/run_summary.h"

namespace dygslam {
class RgbdDataset;
struct StampedPose;
struct SystemOptions;
}  // namespace dygslam

namespace dygslam::cli {

struct Command {
  std::string name;
  std::string summary;                                           // one line for `dygslam help`
  std::function<int(const std::vector<std::string>& args)> run;  // args after the command name
};

// Registered commands, by name.
const std::map<std::string, Command>& Commands();
void RegisterCommand(Command command);

struct CommandRegistrar {
  explicit CommandRegistrar(Command command) { RegisterCommand(std::move(command)); }
};

// Minimal option parser: positionals, `--name value`, `--name=value`, boolean `--flag`, `--help`.
// A separate value that starts with "--" (`--out --no-map`: the value was forgotten) is a usage
// error; such a value is given as `--name=--value`.
class ArgParser {
 public:
  // usage: the part after "dygslam <command> " (e.g. "GROUNDTRUTH ESTIMATE [--json]").
  ArgParser(std::string command, std::string usage, std::string description);

  void AddPositional(const std::string& name, const std::string& help);  // required, in order
  void AddOptionalPositional(const std::string& name, const std::string& help);
  void AddOption(const std::string& name, const std::string& value_name, const std::string& help,
                 const std::string& default_value = "");
  void AddFlag(const std::string& name, const std::string& help);
  // An option bound to a field, read into it by ReadBound() after Parse() (a number checked as
  // GetNumber / GetInt do); its default is the field's value when bound.
  void Bind(const std::string& name, const std::string& value_name, const std::string& help,
            std::string* field);
  void Bind(const std::string& name, const std::string& value_name, const std::string& help,
            double* field, double min_value, double max_value);
  void Bind(const std::string& name, const std::string& value_name, const std::string& help,
            int* field, int min_value, int max_value);
  // A flag bound to a switch: given, it sets the field to `when_given` (--progress: true,
  // --no-mapper: false).
  void BindFlag(const std::string& name, const std::string& help, bool* field,
                bool when_given = true);
  // Every bound option into its field, in the order bound: false after the usage error of the
  // first bad value (exit_code() 2).
  bool ReadBound();

  // False on --help (usage printed to stdout, exit_code() 0) or on a usage error (message and
  // usage printed to stderr, exit_code() 2).
  bool Parse(const std::vector<std::string>& args);
  int exit_code() const { return exit_code_; }

  std::string Positional(const std::string& name) const;  // "" if an optional one is absent
  bool HasPositional(const std::string& name) const;
  bool Has(const std::string& option) const;         // option given (or flag set)
  std::string Get(const std::string& option) const;  // value or default
  bool Flag(const std::string& flag) const;
  std::string Usage() const;
  // Prints "dygslam <command>: <message>" + usage hint to stderr; returns 2.
  int UsageError(const std::string& message) const;
  // The option's value as a whole number in [min_value, max_value] / a finite number in
  // [min_value, max_value] (core/base/number_option.h). On a malformed or out-of-range value:
  // false, after the usage error "--NAME: expected an integer in MIN..MAX, got 'VALUE'"
  // (exit_code() is then 2).
  bool GetInt(const std::string& option, int64_t min_value, int64_t max_value, int64_t* value);
  bool GetInt(const std::string& option, int min_value, int max_value, int* value);
  bool GetNumber(const std::string& option, double min_value, double max_value, double* value);
  // The option's value as `count` finite numbers separated by commas ("6,5,3"). Otherwise false,
  // after the usage error "--NAME: expected FORMAT, got 'VALUE'".
  bool GetNumberList(const std::string& option, size_t count, const std::string& format,
                     std::vector<double>* values);
  // The option's FIRST:LAST range of rgb.txt entries (all `num_entries` when not given); a
  // LAST beyond them is cut, with a warning on stderr. A malformed or empty range: false after
  // the usage error.
  bool GetFrameRange(const std::string& option, size_t num_entries, size_t* first, size_t* last);
  // The same before the dataset is read: LAST 0 when not given (to the end). False after the
  // usage error for a malformed or empty range.
  bool GetOpenFrameRange(const std::string& option, size_t* first, size_t* last);
  // The option's comma-separated items, empty ones left out ("a,,b" -> a, b).
  std::vector<std::string> GetList(const std::string& option) const;
  // An empty or blank option value is a usage error unless allowed here: `dygslam component`
  // allows it, as compose files pass optional settings as empty variables (`--load-octomap ""`:
  // none); the user-facing commands do not (`--config=` would only show up later as a nameless
  // file).
  void AllowEmptyValues() { allow_empty_values_ = true; }

 private:
  struct Spec {
    std::string name, value_name, help, default_value;
    bool is_flag = false;
  };
  std::string command_, usage_, description_;
  std::vector<std::pair<std::string, std::string>> positionals_;  // name, help
  size_t num_required_ = 0;
  std::vector<Spec> options_;
  std::map<std::string, std::string> positional_values_;
  std::map<std::string, std::string> option_values_;
  int exit_code_ = 0;
  bool allow_empty_values_ = false;
  std::vector<std::function<bool()>> bound_;  // ReadBound's readers
};

// Directory of the scripts (scripts/): $DYGSLAM_SCRIPTS_DIR, else the source tree's
// scripts/ baked in at build time, else ../share/dygslam/scripts next to the executable.
std::string ScriptsDir();
// The settings presets folder (config/ beside scripts/).
std::string ConfigDir();
// The output folder given as `--<option> value`, checked before any work: InputError naming the
// option when the value is empty, names something that is not a folder (/etc/passwd), or the
// folder cannot be created or written (a probe file is created and removed, so a read-only folder
// is found up front, not after the whole run). Creates the folder (and missing parents).
// The outputs the command writes there are held for it until it ends (`outputs`: what it writes):
// a second command writing the same kind of outputs into the folder (two runs, a recorder started
// by hand beside a run) is refused with a usage error. The processes a command starts for its own
// run write under its hold.
enum class FolderOutputs { kAll, kTrajectories, kMap };
std::filesystem::path PrepareOutputDir(const std::string& option, const std::string& value,
                                       FolderOutputs outputs = FolderOutputs::kAll);
// Removes the folders PrepareOutputDir created when they are still empty (a command that failed
// before writing anything leaves no empty output folder behind). The dispatcher calls it when a
// command exits non-zero.
void RemoveUnusedOutputDirs();

// How the command line reads settings files: unknown keys warn, or are errors with the flag
// --strict-settings or DYGSLAM_STRICT_SETTINGS=1 (which child processes inherit). Warnings are not
// printed again where DYGSLAM_SETTINGS_WARNED is set (a parent `run` printed them).
SettingsReadOptions CliSettingsReadOptions(bool strict_flag);
// The flags of the commands that run the SLAM on a dataset folder (run, map), in this order:
// --quiet, --strict-settings, --strict-paths.
void AddDatasetRunFlags(ArgParser* p);

// The --filter value of run / map / component / bench checked as a usage error naming the option
// ("--filter 'x': unknown filter (expected none | boxes | ...)"); false after printing it (the
// command then exits 2).
bool CheckFilterOption(ArgParser* p);
// The settings of a command that runs the SLAM (LoadRunConfiguration): its --filter (default
// full), --deterministic and --strict-settings, where the command has them.
RunConfiguration LoadCommandSettings(const ArgParser& p, const std::string& settings_path);
// --domain, --partition (`partition_default`: what it is when not given) and --security of the
// DDS pipeline (run, component); --security's default is $DYGSLAM_DDS_SECURITY_DIR.
void AddDdsRunOptions(ArgParser* p, const std::string& partition_default);
// --save-map, --load-map, --localization and --load-octomap (run, component).
void AddMapFileOptions(ArgParser* p);
// --partition (run, component): a plain name; wildcards would join other runs' partitions. False
// after printing the usage error.
bool CheckPartitionOption(ArgParser* p);

}  // namespace dygslam::cli
