#include "apps/command.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <optional>
#include <sstream>
#include <tuple>

#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/base/number_option.h"
#include "core/io/dataset.h"
#include "core/io/file_util.h"
#include "core/io/trajectory_io.h"
#include "core/slam/map/map_file.h"
#include "core/system/system.h"
#include "run/realtime_report.h"
#include "run/run_settings.h"

namespace dygslam::cli {
namespace {
std::map<std::string, Command>& MutableCommands() {
  static std::map<std::string, Command> commands;
  return commands;
}
}  // namespace

const std::map<std::string, Command>& Commands() { return MutableCommands(); }

void RegisterCommand(Command command) {
  const std::string name = command.name;
  MutableCommands()[name] = std::move(command);
}

std::string ScriptsDir() {
  namespace fs = std::filesystem;
  if (const char* env = std::getenv("DYGSLAM_SCRIPTS_DIR"); env != nullptr && *env != '\0')
    return env;
  std::error_code ec;
#ifdef DYGSLAM_SOURCE_SCRIPTS_DIR
  if (fs::is_directory(DYGSLAM_SOURCE_SCRIPTS_DIR, ec)) return DYGSLAM_SOURCE_SCRIPTS_DIR;
#endif
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = exe.parent_path() / "../share/dygslam/scripts";
    if (fs::is_directory(installed, ec)) return fs::canonical(installed, ec).string();
  }
  return "scripts";
}

namespace {
std::vector<std::filesystem::path>& CreatedOutputDirs() {
  static std::vector<std::filesystem::path> dirs;
  return dirs;
}
}  // namespace

void RemoveUnusedOutputDirs() {
  std::error_code ec;
  // Deepest first; std::filesystem::remove leaves a folder that holds anything.
  for (const std::filesystem::path& d : CreatedOutputDirs()) {
    if (std::filesystem::is_directory(d, ec) && std::filesystem::is_empty(d, ec))
      std::filesystem::remove(d, ec);
  }
  CreatedOutputDirs().clear();
}

namespace {

[[noreturn]] void RefuseHeldFolder(const std::string& name, const std::string& what) {
  throw InvalidOptions(name + ": another dygslam command is writing its " + what +
                       " into this folder (a run, a recorder or a mapper); their outputs would "
                       "replace each other: wait for it to end or choose another folder");
}

// One command writes one kind of output (trajectories, the map) into a folder at a time, held
// until the process ends (the kernel drops the locks, SIGKILL included). A command writing every
// kind (run, map, bench, bridge) locks the folder itself exclusively; a recorder or mapper
// component locks it shared (a hand-assembled pipeline's recorder and mapper share one --out)
// plus a lock of its kind (a lock file in the folder). Both hold for every user, environment and
// mount namespace that sees the folder. A second writer is refused before any work: it would rename
// its files over the other's, complete ones by partial ones. The processes a command starts for
// its own run (`run --processes`) find the folder in DYGSLAM_HELD_FOLDERS and write under its
// hold.
void LockOutputFolder(const std::string& name, const std::filesystem::path& dir,
                      FolderOutputs outputs) {
  struct stat st {};
  if (::stat(dir.c_str(), &st) != 0) return;  // the first write names the problem
  const std::string id = std::to_string(static_cast<unsigned long long>(st.st_dev)) + ":" +
                         std::to_string(static_cast<unsigned long long>(st.st_ino));
  const char* held_env = std::getenv("DYGSLAM_HELD_FOLDERS");
  const std::string held = held_env ? held_env : "";
  if (("," + held + ",").find("," + id + ",") != std::string::npos) return;
  const bool all = outputs == FolderOutputs::kAll;
  // Held (the descriptors stay open) until the process ends.
  const int folder_fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (folder_fd >= 0 && ::flock(folder_fd, (all ? LOCK_EX : LOCK_SH) | LOCK_NB) != 0) {
    const int error = errno;
    ::close(folder_fd);
    if (error == EWOULDBLOCK) RefuseHeldFolder(name, "outputs");
  }
  if (!all && folder_fd >= 0) {
    // The lock of its kind is a file in the folder itself (the same file for every user, mount
    // namespace and private /tmp that sees the folder), opened without following a link and
    // never truncated; it stays, empty, beside the outputs.
    const char* kind = outputs == FolderOutputs::kMap ? "map" : "trajectories";
    const std::string file = std::string(".dygslam-lock.") + kind;
    // O_NONBLOCK: a FIFO planted under the name is opened at once (and refused), not waited on.
    const int fd = ::openat(folder_fd, file.c_str(),
                            O_RDONLY | O_CREAT | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK, 0644);
    struct stat lock_st {};
    if (fd < 0 || ::fstat(fd, &lock_st) != 0 || !S_ISREG(lock_st.st_mode)) {
      const std::string why = fd < 0 ? std::strerror(errno) : "it is not a plain file";
      if (fd >= 0) ::close(fd);
      throw InputError(name + ": cannot open the lock file " + file + " of its " + kind + ": " +
                       why + " (remove it if it is not a plain file)");
    }
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int error = errno;
      ::close(fd);
      if (error == EWOULDBLOCK) RefuseHeldFolder(name, kind);
    }
  }
  if (all) ::setenv("DYGSLAM_HELD_FOLDERS", (held.empty() ? id : held + "," + id).c_str(), 1);
}

}  // namespace

std::filesystem::path PrepareOutputDir(const std::string& option, const std::string& value,
                                       FolderOutputs outputs) {
  namespace fs = std::filesystem;
  const std::string name = "--" + option + " '" + EchoValue(value) + "'";
  if (value.empty()) throw InputError("--" + option + ": empty folder name");
  std::error_code ec;
  const fs::path dir(value);
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
    throw InputError(name + ": exists and is not a folder");
  // A dataset folder (TUM / Bonn layout) is never an output folder: the run writes
  // groundtruth.txt and would replace the dataset's own.
  if (IsDatasetFolder(dir))
    throw InputError(name +
                     ": is a dataset folder (it holds rgb.txt and depth.txt, or "
                     "associations.txt); the outputs "
                     "(groundtruth.txt, trajectory.txt, ...) would overwrite its files: choose "
                     "another folder");
  if (const std::string images = DatasetImageFolderOf(dir); !images.empty())
    throw InputError(name + ": lies in the image folder '" + EchoValue(images) +
                     "' of a dataset; the outputs would be mixed with its images: choose another "
                     "folder");
  // The folders this call creates (deepest first), removed again by RemoveUnusedOutputDirs when
  // the command fails before writing anything into them.
  std::vector<fs::path> created;
  for (fs::path d = dir.lexically_normal(); !d.empty() && !fs::exists(d, ec); d = d.parent_path()) {
    created.push_back(d);
    if (d == d.parent_path()) break;
  }
  fs::create_directories(dir, ec);
  if (ec) throw InputError(name + ": cannot create the folder: " + ec.message());
  CreatedOutputDirs().insert(CreatedOutputDirs().end(), created.begin(), created.end());
  // Writable: a probe file made new under a random name (O_EXCL: never a file or link that is
  // there already), removed at once.
  std::string probe = (dir / ".dygslam_write_probe.XXXXXX").string();
  const int probe_fd = ::mkstemp(probe.data());
  if (probe_fd < 0) throw InputError(name + ": folder is not writable: " + std::strerror(errno));
  ::close(probe_fd);
  ::unlink(probe.c_str());
  PinOutputFolder(dir.string());  // a folder replaced while the command runs is not written into
  LockOutputFolder(name, dir, outputs);
  return dir;
}

SettingsReadOptions CliSettingsReadOptions(bool strict_flag) {
  SettingsReadOptions options;
  const char* env = std::getenv("DYGSLAM_STRICT_SETTINGS");
  if (strict_flag || (env != nullptr && std::string(env) == "1"))
    options.unknown_keys = UnknownKeyPolicy::kError;
  // A `run --processes` parent has printed the warnings already; its components stay quiet.
  options.print_warnings = std::getenv("DYGSLAM_SETTINGS_WARNED") == nullptr;
  return options;
}

void AddDatasetRunFlags(ArgParser* p) {
  p->AddFlag("quiet", "no progress line");
  p->AddFlag("strict-settings",
             "unknown keys in the settings file are errors, not warnings (also "
             "DYGSLAM_STRICT_SETTINGS=1)");
  p->AddFlag("strict-paths", "image paths outside DATASET_DIR are errors, not warnings");
}

RunConfiguration LoadCommandSettings(const ArgParser& p, const std::string& settings_path) {
  const std::string filter = p.Get("filter");
  return LoadRunConfiguration({settings_path, CliSettingsReadOptions(p.Flag("strict-settings")),
                               filter.empty() ? "full" : filter, p.Flag("deterministic")});
}

void AddDdsRunOptions(ArgParser* p, const std::string& partition_default) {
  p->AddOption("domain", "N", "DDS domain id (default: $DYGSLAM_DOMAIN_ID or 0)", "-1");
  p->AddOption("partition", "NAME",
               "DDS partition of the pipeline topics (default: " + partition_default + ")");
  const char* security_env = std::getenv("DYGSLAM_DDS_SECURITY_DIR");
  p->AddOption("security", "DIR",
               "DDS Security: make_dds_certs.sh's OUT_DIR (one identity folder per component) or "
               "one identity folder (default: $DYGSLAM_DDS_SECURITY_DIR; none = off)",
               security_env != nullptr ? security_env : "");
}

void AddMapFileOptions(ArgParser* p) {
  p->AddOption("save-map", "FILE",
               "write the SLAM map (keyframes, points, BoW) to FILE at the end, also when stopped");
  p->AddOption("load-map", "FILE",
               "start from the SLAM map in FILE (made with the same camera, ORB and vocabulary);\n"
               "without --localization it is extended");
  p->AddFlag("localization",
             "with --load-map: track against the loaded map without adding keyframes or points");
  p->AddOption("load-octomap", "FILE",
               "continue this OctoMap (.ot, e.g. map.ot of a --save-map run): keyframes are\n"
               "inserted on top; in --localization it is the map");
}

bool CheckPartitionOption(ArgParser* p) {
  if (p->Get("partition").find_first_of("*?[]") == std::string::npos) return true;
  p->UsageError("--partition '" + EchoValue(p->Get("partition")) +
                "': wildcards (* ? [ ]) would join other runs; give a plain name");
  return false;
}

bool CheckFilterOption(ArgParser* p) {
  try {
    SystemOptions scratch;
    ApplyFilterConfiguration(p->Get("filter"), &scratch);
    return true;
  } catch (const InvalidOptions&) {
    std::string list;
    for (const std::string& name : FilterConfigurationNames())
      list += (list.empty() ? "" : " | ") + name;
    p->UsageError("--filter '" + EchoValue(p->Get("filter")) + "': unknown filter (expected " +
                  list + ")");
    return false;
  }
}

ArgParser::ArgParser(std::string command, std::string usage, std::string description)
    : command_(std::move(command)),
      usage_(std::move(usage)),
      description_(std::move(description)) {}

void ArgParser::AddPositional(const std::string& name, const std::string& help) {
  positionals_.insert(positionals_.begin() + num_required_, {name, help});
  ++num_required_;
}

void ArgParser::AddOptionalPositional(const std::string& name, const std::string& help) {
  positionals_.emplace_back(name, help);
}

void ArgParser::AddOption(const std::string& name, const std::string& value_name,
                          const std::string& help, const std::string& default_value) {
  options_.push_back({name, value_name, help, default_value, false});
}

void ArgParser::AddFlag(const std::string& name, const std::string& help) {
  options_.push_back({name, "", help, "", true});
}

void ArgParser::Bind(const std::string& name, const std::string& value_name,
                     const std::string& help, std::string* field) {
  AddOption(name, value_name, help, *field);
  bound_.push_back([this, name, field] {
    *field = Get(name);
    return true;
  });
}

void ArgParser::Bind(const std::string& name, const std::string& value_name,
                     const std::string& help, double* field, double min_value, double max_value) {
  std::ostringstream text;
  text << *field;
  AddOption(name, value_name, help, text.str());
  bound_.push_back([=] { return GetNumber(name, min_value, max_value, field); });
}

void ArgParser::Bind(const std::string& name, const std::string& value_name,
                     const std::string& help, int* field, int min_value, int max_value) {
  AddOption(name, value_name, help, std::to_string(*field));
  bound_.push_back([=] { return GetInt(name, min_value, max_value, field); });
}

void ArgParser::BindFlag(const std::string& name, const std::string& help, bool* field,
                         bool when_given) {
  AddFlag(name, help);
  bound_.push_back([=] {
    if (Flag(name)) *field = when_given;
    return true;
  });
}

bool ArgParser::ReadBound() {
  for (const auto& read : bound_)
    if (!read()) return false;
  return true;
}

std::string ArgParser::Usage() const {
  std::ostringstream out;
  out << "usage: dygslam " << command_ << " " << usage_ << "\n";
  if (!description_.empty()) out << "\n" << description_ << "\n";
  if (!positionals_.empty()) {
    out << "\narguments:\n";
    for (const auto& [name, help] : positionals_) {
      std::string left = "  " + name;
      left.resize(std::max<size_t>(left.size() + 2, 26), ' ');
      out << left << help << "\n";
    }
  }
  out << "\noptions:\n";
  for (const Spec& s : options_) {
    std::string left = "  --" + s.name + (s.is_flag ? "" : " " + s.value_name);
    left.resize(std::max<size_t>(left.size() + 2, 26), ' ');
    out << left << s.help;
    if (!s.default_value.empty()) out << " (default: " << s.default_value << ")";
    out << "\n";
  }
  out << "  --help                  show this help\n";
  return out.str();
}

int ArgParser::UsageError(const std::string& message) const {
  // Bounded: a message may quote a megabyte-long option value (core/base/echo.h).
  std::cerr << "dygslam " << command_ << ": " << BoundedMessage(message) << "\n"
            << "usage: dygslam " << command_ << " " << usage_ << "\n"
            << "(dygslam " << command_ << " --help for details)\n";
  return 2;
}

bool ArgParser::GetInt(const std::string& option, int64_t min_value, int64_t max_value,
                       int64_t* value) {
  try {
    *value = IntegerOption(option, Get(option), min_value, max_value);
    return true;
  } catch (const InvalidOptions& e) {
    exit_code_ = UsageError(e.what());
    return false;
  }
}

bool ArgParser::GetInt(const std::string& option, int min_value, int max_value, int* value) {
  int64_t v = 0;
  if (!GetInt(option, int64_t{min_value}, int64_t{max_value}, &v)) return false;
  *value = static_cast<int>(v);
  return true;
}

bool ArgParser::GetNumber(const std::string& option, double min_value, double max_value,
                          double* value) {
  try {
    *value = NumberOption(option, Get(option), min_value, max_value);
    return true;
  } catch (const InvalidOptions& e) {
    exit_code_ = UsageError(e.what());
    return false;
  }
}

bool ArgParser::GetNumberList(const std::string& option, size_t count, const std::string& format,
                              std::vector<double>* values) {
  values->clear();
  const std::string text = Get(option);
  for (size_t start = 0; start <= text.size();) {
    const size_t comma = text.find(',', start);
    const std::optional<double> v = ParseFiniteNumber(
        text.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (!v) break;
    values->push_back(*v);
    if (comma == std::string::npos) {
      if (values->size() == count) return true;
      break;
    }
    start = comma + 1;
  }
  exit_code_ =
      UsageError("--" + option + ": expected " + format + ", got '" + EchoValue(text) + "'");
  return false;
}

bool ArgParser::GetFrameRange(const std::string& option, size_t num_entries, size_t* first,
                              size_t* last) {
  *first = 0;
  *last = num_entries;
  if (!Has(option)) return true;
  std::string note;  // LAST beyond the dataset: cut, with a warning
  try {  // a malformed or out-of-range range is a usage error (exit 2), as other numbers
    std::tie(*first, *last) = ParseFrameRange(Get(option), num_entries, &note);
  } catch (const std::exception& e) {
    exit_code_ = UsageError(e.what());
    return false;
  }
  if (!note.empty())
    std::fprintf(stderr, "dygslam %s: warning: %s\n", command_.c_str(), note.c_str());
  return true;
}

bool ArgParser::GetOpenFrameRange(const std::string& option, size_t* first, size_t* last) {
  try {
    const FrameRangeText range = SplitFrameRange(Get(option));
    *first = range.first.value_or(0);
    *last = range.last.value_or(0);  // 0: to the end
  } catch (const InvalidOptions& e) {
    exit_code_ = UsageError(e.what());
    return false;
  }
  if (*last != 0 && *last <= *first) {
    exit_code_ = UsageError("--" + option + " '" + EchoValue(Get(option)) +
                            "': empty range (LAST must be above FIRST)");
    return false;
  }
  return true;
}

std::vector<std::string> ArgParser::GetList(const std::string& option) const {
  std::vector<std::string> items;
  std::stringstream list(Get(option));
  for (std::string item; std::getline(list, item, ',');)
    if (!item.empty()) items.push_back(item);
  return items;
}

bool ArgParser::Parse(const std::vector<std::string>& args) {
  positional_values_.clear();
  option_values_.clear();
  size_t next_positional = 0;
  bool only_positionals = false;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (!only_positionals && (a == "--help" || a == "-h")) {
      std::cout << Usage();
      exit_code_ = 0;
      return false;
    }
    if (!only_positionals && a == "--") {
      only_positionals = true;
      continue;
    }
    if (!only_positionals && a.size() > 2 && a.compare(0, 2, "--") == 0) {
      std::string name = a.substr(2), value;
      bool has_value = false;
      if (const size_t eq = name.find('='); eq != std::string::npos) {
        value = name.substr(eq + 1);
        name = name.substr(0, eq);
        has_value = true;
      }
      const Spec* spec = nullptr;
      for (const Spec& s : options_) {
        if (s.name == name) spec = &s;
      }
      if (spec == nullptr) {
        exit_code_ = UsageError("unknown option --" + EchoValue(name));
        return false;
      }
      if (spec->is_flag) {
        if (has_value) {
          exit_code_ = UsageError("option --" + EchoValue(name) + " takes no value");
          return false;
        }
        option_values_[name] = "1";
        continue;
      }
      if (!has_value) {
        if (i + 1 >= args.size()) {
          exit_code_ = UsageError("option --" + name + " needs a value (" + spec->value_name + ")");
          return false;
        }
        // `--out --no-map`: the value is missing and the next option would be taken for it.
        if (args[i + 1].rfind("--", 0) == 0) {
          exit_code_ =
              UsageError("option --" + name + " needs a value (" + spec->value_name +
                         "), got the option '" + EchoValue(args[i + 1]) +
                         "' (a value that starts with '--' is given as --" + name + "=VALUE)");
          return false;
        }
        value = args[++i];
      }
      // `--config=` or `--out " "`: no option takes an empty or blank value (a path of spaces
      // would only show up as an invisible name in a later error).
      if (!allow_empty_values_ && value.find_first_not_of(" \t\n\r\f\v") == std::string::npos) {
        exit_code_ = UsageError("option --" + name + " needs a value (" + spec->value_name +
                                "), got " + (value.empty() ? "an empty one" : "only blanks"));
        return false;
      }
      // Given twice with different values (`--out a --out b`): one of them would be ignored
      // without a word.
      if (const auto it = option_values_.find(name);
          it != option_values_.end() && it->second != value) {
        exit_code_ =
            UsageError("option --" + name + " given twice with different values ('" +
                       EchoValue(it->second) + "', '" + EchoValue(value) + "'): give it once");
        return false;
      }
      option_values_[name] = value;
      continue;
    }
    if (next_positional >= positionals_.size()) {
      exit_code_ = UsageError("unexpected argument '" + EchoValue(a) + "'");
      return false;
    }
    positional_values_[positionals_[next_positional++].first] = a;
  }
  if (next_positional < num_required_) {
    exit_code_ = UsageError("missing argument " + positionals_[next_positional].first);
    return false;
  }
  exit_code_ = 0;
  return true;
}

std::string ArgParser::Positional(const std::string& name) const {
  auto it = positional_values_.find(name);
  return it == positional_values_.end() ? "" : it->second;
}

bool ArgParser::HasPositional(const std::string& name) const {
  return positional_values_.count(name) > 0;
}

bool ArgParser::Has(const std::string& option) const { return option_values_.count(option) > 0; }

std::string ArgParser::Get(const std::string& option) const {
  auto it = option_values_.find(option);
  if (it != option_values_.end()) return it->second;
  for (const Spec& s : options_) {
    if (s.name == option) return s.default_value;
  }
  return "";
}

bool ArgParser::Flag(const std::string& flag) const { return Has(flag); }

std::string ConfigDir() {
  return (std::filesystem::path(ScriptsDir()).parent_path() / "config").string();
}

}  // namespace dygslam::cli
