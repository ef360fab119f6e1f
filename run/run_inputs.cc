#include "run/run_inputs.h"

#include <octomap/OcTree.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/dynamic/yolo_detector.h"
#include "core/io/detections_io.h"
#include "core/io/trajectory_io.h"
#include "core/slam/map/map_file.h"
#include "mapping/octomap_builder.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

// Lines of a class names file that name a class (0 when there is no such file).
int CountClassNames(const std::string& path) {
  std::error_code ec;
  if (path.empty() || !fs::is_regular_file(path, ec)) return 0;
  std::ifstream in(path);
  int n = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.find_first_not_of(" \t\r") != std::string::npos) ++n;
  }
  return n;
}

}  // namespace

std::vector<StampedPose> ReadRunGroundTruth(const RgbdDataset& dataset) {
  // Found here, before any frame: the run goes on without evaluation (its trajectory is what
  // matters; `dygslam eval` scores it once the file is fixed).
  std::vector<StampedPose> groundtruth;
  if (dataset.has_groundtruth()) {
    try {
      groundtruth = ReadTumTrajectory(dataset.groundtruth_path());
    } catch (const InputError& e) {
      groundtruth.clear();
      std::fprintf(stderr,
                   "dygslam run: warning: %s; the run goes on without evaluation (fix the file, "
                   "then `dygslam eval GROUNDTRUTH OUT/trajectory.txt`)\n",
                   e.what());
    }
  } else if (!dataset.groundtruth_problem().empty()) {
    std::fprintf(stderr,
                 "dygslam run: warning: %s; the run goes on without evaluation (replace it by "
                 "the ground truth file, then `dygslam eval GROUNDTRUTH OUT/trajectory.txt`)\n",
                 EchoValue(dataset.groundtruth_problem(), 500).c_str());
  }
  return groundtruth;
}

DetectionsByStamp ReadRunDetections(const std::string& path, const SystemOptions& system) {
  DetectorOptions names_of = system.detector;
  if (names_of.names_path.empty()) {
    try {
      names_of = DetectorOptionsForModel("yolo-fastest-1.1");
    } catch (const InputError&) {  // no models here: class ids are not checked
    }
  }
  return ReadDetections(path, CountClassNames(names_of.names_path), names_of.names_path);
}

void WarnUnmatchedDetections(const std::string& path, const DetectionsByStamp& detections,
                             const PinholeCamera& camera, const RgbdDataset& dataset, size_t first,
                             size_t last) {
  size_t frames = 0, frames_with_boxes = 0;
  for (size_t k = first; k < last; ++k) {
    const auto index = dataset.FrameForRgbEntry(k);
    if (!index) continue;
    ++frames;
    if (!DetectionsNear(detections, dataset.frame(*index).rgb_stamp).empty()) ++frames_with_boxes;
  }
  size_t stamps_unmatched = 0;
  for (const auto& [stamp, boxes] : detections) {
    bool matched = false;
    for (const RgbdFrameEntry& f : dataset.frames()) {
      if (std::abs(SecondsBetween(stamp, f.rgb_stamp)) <= 0.02) {
        matched = true;
        break;
      }
    }
    if (!matched) ++stamps_unmatched;
  }
  // Boxes that do not overlap the image (pixels in another resolution, a unit mix-up) mask
  // nothing: said, with how many.
  size_t boxes = 0, boxes_outside = 0;
  const cv::Rect2f image(0.f, 0.f, static_cast<float>(camera.width),
                         static_cast<float>(camera.height));
  for (const auto& [stamp, frame_boxes] : detections) {
    for (const Detection& d : frame_boxes) {
      ++boxes;
      if ((d.box & image).area() <= 0.f) ++boxes_outside;
    }
  }
  if (boxes_outside > 0) {
    std::fprintf(stderr,
                 "dygslam run: warning: --detections %s: %zu of its %zu boxes lie outside the "
                 "%dx%d image (Camera.width x Camera.height) and mask nothing\n",
                 EchoValue(path).c_str(), boxes_outside, boxes, camera.width, camera.height);
  }
  if (stamps_unmatched == 0 && (frames_with_boxes > 0 || detections.empty())) return;
  std::fprintf(stderr,
               "dygslam run: warning: --detections %s: %zu of its %zu stamps match no frame of "
               "the dataset (within 0.02 s); %zu of the run's %zu frames have boxes, %zu have "
               "none%s\n",
               EchoValue(path).c_str(), stamps_unmatched, detections.size(), frames_with_boxes,
               frames, frames - frames_with_boxes,
               frames_with_boxes == 0 ? " (the file matches no frame: no box is used; is it of "
                                        "another sequence?)"
                                      : "");
}

void WarnAboutDataset(const std::string& command, const RgbdDataset& dataset, size_t first,
                      size_t last, double depth_map_factor, int width, int height,
                      const std::vector<StampedPose>* groundtruth) {
  const auto warn = [&](const std::string& text) {
    std::fprintf(stderr, "dygslam %s: warning: %s\n", command.c_str(), text.c_str());
  };
  if (!dataset.listing_problem().empty()) warn(EchoValue(dataset.listing_problem(), 600));
  // Depth that no RGB-D sensor measures on most pixels (every pixel saturated, DepthMapFactor off
  // by orders of magnitude) would run to the end with a meaningless map and trajectory.
  if (const std::string why =
          ImplausibleDepth(SampleDepthRange(dataset, first, last, depth_map_factor, width, height),
                           depth_map_factor);
      !why.empty())
    warn("implausible depth: " + why);
  if (groundtruth != nullptr) {
    if (const std::string note = GroundTruthCoverageNote(dataset, first, last, *groundtruth);
        !note.empty())
      warn(EchoValue(note, 600));
    if (const std::string note =
            ImplausibleGroundTruthNote(dataset.groundtruth_path(), *groundtruth);
        !note.empty())
      warn(EchoValue(note, 600));
  }
}

std::vector<StampedPose> ReadGroundTruthAndWarn(const std::string& command,
                                                const RunControllerOptions& options,
                                                const RgbdDataset& dataset,
                                                const std::string& detections_path) {
  std::vector<StampedPose> groundtruth = ReadRunGroundTruth(dataset);
  const SystemOptions& system = options.system;
  if (options.use_detection_file)
    WarnUnmatchedDetections(detections_path, options.detections, system.camera, dataset,
                            options.first, options.last);
  WarnAboutDataset(command, dataset, options.first, options.last, system.sensor.depth_map_factor,
                   system.camera.width, system.camera.height,
                   groundtruth.empty() ? nullptr : &groundtruth);
  return groundtruth;
}

void CheckOctoMapToContinue(const std::string& option, const std::string& path) {
  try {
    ReadOctoMap(path);
  } catch (const InputError& e) {
    throw InputError(option + ": " + e.what());
  }
}

void ReadRunInputFiles(const RunInputFiles& files, RunControllerOptions* options) {
  RunControllerOptions& s = *options;
  if (files.localization && files.load_map.empty())
    throw UsageError("--localization needs --load-map FILE");
  if (!files.save_map.empty()) {
    s.save_map = files.save_map;
    CheckMapFileWritable(s.save_map);
  }
  if (!files.load_octomap.empty()) {
    if (!s.map) throw UsageError("--load-octomap and --no-map exclude each other");
    s.load_octomap = files.load_octomap;
    CheckOctoMapToContinue("--load-octomap", s.load_octomap);
  }
  if (!files.load_map.empty()) {
    // Checked before any work: a bad map is an error naming the file, no output is written.
    s.system.load_map = files.load_map;
    s.system.localization = files.localization;
    std::printf("map file: loaded %s (%s)%s\n", s.system.load_map.c_str(),
                DescribeMapFile(CheckMapFile(s.system.load_map, s.system)).c_str(),
                s.system.localization ? ", localization mode" : "");
  }
  if (!files.detections.empty()) {
    s.detections = ReadRunDetections(files.detections, s.system);
    s.use_detection_file = true;
  }
}

}  // namespace dygslam
