#include "tools/synth/sequence_folder.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>

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

}  // namespace

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
  fs::remove(marker, ec);
  for (const auto& entry : fs::directory_iterator(staging)) {
    const fs::path destination = target / entry.path().filename();
    fs::remove_all(destination, ec);
    fs::rename(entry.path(), destination, ec);
    if (ec)
      throw InputError(destination.string(), 0,
                       "cannot move the rendered sequence into place: " + ec.message() +
                           " (the rendered files are in " + staging.string() + ")");
  }
  fs::remove(staging, ec);
  // The pairs of the dataset replaced (a reader prefers associations.txt to rgb.txt + depth.txt)
  // are not this sequence's.
  if (const fs::path stale = target / "associations.txt";
      fs::exists(fs::symlink_status(stale, ec))) {
    fs::remove(stale, ec);
    std::fprintf(stderr,
                 "synth: removed %s (the frame pairs of the replaced dataset; this sequence is "
                 "read from rgb.txt and depth.txt)\n",
                 EchoValue(stale.string()).c_str());
  }
  std::printf("wrote %d frames (%dx%d, %d moving objects, seed %llu) to %s in %.2f s\n",
              options.num_frames, options.camera.width, options.camera.height,
              options.num_moving_objects, static_cast<unsigned long long>(options.seed),
              out_dir.c_str(), elapsed());
}

}  // namespace dygslam
