#include "tools/synth/sequence_folder.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <vector>

#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/base/stop_signal.h"
#include "core/io/dataset.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

// The files of a sequence that synth writes (and --replace replaces).
const char* const kSequenceFiles[] = {"rgb.txt",         "depth.txt",  "associations.txt",
                                      "groundtruth.txt", "mask.txt",   "detections.txt",
                                      "objects.txt",     "camera.yaml"};
const char* const kSequenceFolders[] = {"rgb", "depth", "mask"};
// The staging folder OUT_DIR/.synth-partial holds this file from its start: one without it is
// not synth's.
const char* const kStagingMarker = ".dygslam-synth-render";
// While --replace moves the render in, the replaced sequence's files wait in
// OUT_DIR/.synth-previous (this marker from its start; kAllMoved once every one of them is there)
// until the new ones are all in place: a synth killed midway leaves one whole sequence to restore.
const char* const kPreviousMarker = ".dygslam-synth-previous";
const char* const kAllMoved = ".all-moved";

fs::path StagingOf(const fs::path& out_dir) { return out_dir / ".synth-partial"; }
fs::path PreviousOf(const fs::path& out_dir) { return out_dir / ".synth-previous"; }

bool IsSequenceName(const std::string& name) {
  for (const char* n : kSequenceFiles)
    if (name == n) return true;
  for (const char* n : kSequenceFolders)
    if (name == n) return true;
  return false;
}

// Renames `from` to `to` (an InputError naming both when it fails).
void Move(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  fs::rename(from, to, ec);
  if (ec)
    throw InputError(from.string(), 0,
                     "cannot move it to " + to.string() + ": " + ec.message() +
                         " (nothing was removed: the files are where the message says)");
}

// The entries of `folder` other than the markers.
std::vector<fs::path> EntriesOf(const fs::path& folder) {
  std::vector<fs::path> entries;
  std::error_code ec;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name != kStagingMarker && name != kPreviousMarker && name != kAllMoved)
      entries.push_back(it->path());
  }
  return entries;
}

// Removes the replaced sequence set aside: renamed first, so that a removal cut short never
// leaves a .synth-previous with part of its files.
void RemoveSetAside(const fs::path& previous) {
  const fs::path done = previous.string() + ".done";
  std::error_code ec;
  fs::remove_all(done, ec);
  fs::rename(previous, done, ec);
  fs::remove_all(ec ? previous : done, ec);
}

// The render in `staging` in place of OUT_DIR's sequence: the old files are moved aside first,
// then the new ones in, then the old ones removed; never a moment where a file is deleted before
// a whole sequence (old or new) can be put back by RecoverInterruptedReplace.
void MoveIntoPlace(const fs::path& target, const fs::path& staging) {
  const fs::path previous = PreviousOf(target);
  std::error_code ec;
  fs::create_directory(previous, ec);
  std::ofstream(previous / kPreviousMarker) << "the sequence dygslam synth --replace replaces\n";
  for (fs::directory_iterator it(target, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (IsSequenceName(name)) Move(it->path(), previous / name);
  }
  std::ofstream(previous / kAllMoved) << "every file of the replaced sequence is here\n";
  for (const fs::path& entry : EntriesOf(staging)) Move(entry, target / entry.filename());
  fs::remove_all(staging, ec);  // its marker: the new sequence is in place
  RemoveSetAside(previous);
}

}  // namespace

std::string RecoverInterruptedReplace(const std::string& out_dir) {
  const fs::path target(out_dir), previous = PreviousOf(target), staging = StagingOf(target);
  std::error_code ec;
  fs::remove_all(previous.string() + ".done", ec);  // a removal that was cut short
  if (!fs::exists(fs::symlink_status(previous, ec))) return "";
  if (!fs::is_regular_file(fs::symlink_status(previous / kPreviousMarker, ec)))
    throw InputError(previous.string(), 0,
                     "not a sequence that dygslam synth --replace set aside: remove it or choose "
                     "another folder");
  const bool all_moved = fs::exists(previous / kAllMoved, ec);
  if (all_moved && EntriesOf(staging).empty()) {
    // Every new file was in place: the replacement was complete.
    fs::remove_all(staging, ec);
    RemoveSetAside(previous);
    return "completed the replacement of " + EchoValue(out_dir) +
           " that a killed synth had made (the new sequence is in place)";
  }
  if (all_moved) {
    // New files were moving in: they go (the render is in part elsewhere), the old ones return.
    for (fs::directory_iterator it(target, ec), end; !ec && it != end; it.increment(ec))
      if (IsSequenceName(it->path().filename().string())) fs::remove_all(it->path(), ec);
  }
  for (const fs::path& entry : EntriesOf(previous)) Move(entry, target / entry.filename());
  RemoveSetAside(previous);
  return "restored the sequence in " + EchoValue(out_dir) +
         " that a killed synth --replace was replacing";
}

std::string FindDatasetFiles(const std::string& out_dir) {
  std::string found;
  std::error_code ec;
  for (const char* name : kSequenceFiles)
    if (fs::exists(fs::symlink_status(fs::path(out_dir) / name, ec)))
      found += (found.empty() ? "" : ", ") + std::string(name);
  for (const char* name : kSequenceFolders)
    if (fs::exists(fs::symlink_status(fs::path(out_dir) / name, ec)))
      found += (found.empty() ? "" : ", ") + std::string(name);
  if (found.empty()) return "";
  return "OUT_DIR '" + EchoValue(out_dir) + "' holds a dataset (" + found +
         "): writing the sequence would replace its files; choose a new folder or give --replace";
}

std::string FindUnreplaceableFile(const std::string& out_dir) {
  std::error_code ec;
  for (const char* name : kSequenceFolders) {
    const fs::path folder = fs::path(out_dir) / name;
    const fs::file_status status = fs::symlink_status(folder, ec);
    if (!fs::exists(status) || fs::is_symlink(status)) continue;  // a link: only it is replaced
    if (!fs::is_directory(status))
      return "OUT_DIR '" + EchoValue(out_dir) + "': " + name +
             " is not a folder of images; --replace replaces a sequence's files only: move it "
             "or choose another folder";
    for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
      // A sequence's image is named by its timestamp (1305031102.175304.png).
      const std::string stem = it->path().stem().string();
      const bool stamp_named =
          !stem.empty() && stem.find_first_not_of("0123456789.") == std::string::npos;
      if (!HasImageExtension(it->path()) || !stamp_named ||
          !fs::is_regular_file(it->symlink_status()))
        return "OUT_DIR '" + EchoValue(out_dir) + "': '" + EchoValue(it->path().string()) +
               "' is not an image of a sequence (a .png / .jpg named by its timestamp); "
               "--replace " +
               "replaces the sequence's files and image folders only: move it or choose another " +
               "folder";
    }
    if (ec)
      return "OUT_DIR '" + EchoValue(out_dir) + "': cannot read " + name + "/: " + ec.message();
  }
  return "";
}

std::string FindForeignStaging(const std::string& out_dir) {
  const fs::path staging = fs::path(out_dir) / ".synth-partial";
  std::error_code ec;
  if (!fs::exists(fs::symlink_status(staging, ec))) return "";
  if (fs::is_directory(fs::symlink_status(staging, ec)) &&
      fs::is_regular_file(fs::symlink_status(staging / kStagingMarker, ec)))
    return "";
  return "OUT_DIR '" + EchoValue(out_dir) +
         "' holds .synth-partial, which is not an unfinished synth render: remove it or choose "
         "another folder";
}

void RenderIntoPlace(const std::string& out_dir, const SyntheticOptions& options, bool quiet) {
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  const fs::path target = fs::path(out_dir);
  const fs::path staging = target / ".synth-partial";
  const fs::path marker = staging / kStagingMarker;
  std::error_code ec;
  if (fs::exists(fs::symlink_status(staging, ec)))  // checked by FindForeignStaging
    std::fprintf(stderr,
                 "synth: warning: removing %s (the unfinished render of a synth that was "
                 "killed)\n",
                 EchoValue(staging.string()).c_str());
  const ScopedStopSignals stop_signals;
  fs::remove_all(staging, ec);
  fs::create_directories(staging, ec);
  std::ofstream(marker) << "an unfinished render of dygslam synth\n";
  try {
    WriteSyntheticSequence(staging.string(), options, [&](int done, int total) {
      if (const int sig = ScopedStopSignals::Received())
        throw StopSignalError(sig, "stopped by signal " + std::to_string(sig) + " after " +
                                       std::to_string(done) + " of " + std::to_string(total) +
                                       " frames; '" + EchoValue(out_dir) + "' is left as it was");
      if (quiet) return;
      std::fprintf(stderr, "\rsynth: frame %d/%d (%.1f frames/s)", done, total, done / elapsed());
      std::fflush(stderr);
    });
  } catch (...) {
    if (!quiet) std::fprintf(stderr, "\n");
    fs::remove_all(staging, ec);
    throw;
  }
  if (!quiet) std::fprintf(stderr, "\n");
  // The pairs of the dataset replaced (a reader prefers associations.txt to rgb.txt + depth.txt)
  // are not this sequence's: they go with the replaced files.
  const bool stale_pairs = fs::exists(fs::symlink_status(target / "associations.txt", ec));
  MoveIntoPlace(target, staging);
  if (stale_pairs)
    std::fprintf(stderr,
                 "synth: removed %s (the frame pairs of the replaced dataset; this sequence is "
                 "read from rgb.txt and depth.txt)\n",
                 EchoValue((target / "associations.txt").string()).c_str());
  std::printf("wrote %d frames (%dx%d, %d moving objects, seed %llu) to %s in %.2f s\n",
              options.num_frames, options.camera.width, options.camera.height,
              options.num_moving_objects, static_cast<unsigned long long>(options.seed),
              out_dir.c_str(), elapsed());
}

}  // namespace dygslam
