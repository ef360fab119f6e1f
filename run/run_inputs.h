// The inputs of a run besides its settings, each read and checked before any work, with what is
// wrong with them said on stderr ("dygslam run: warning: ..."): the ground truth (optional: it
// only scores the run), a file of boxes per frame (instead of the detector), an OctoMap to
// continue.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "core/base/camera.h"
#include "core/base/timestamp.h"
#include "core/base/types.h"
#include "core/io/dataset.h"
#include "core/system/system.h"
#include "run/run_controller.h"

namespace dygslam {

using DetectionsByStamp = std::map<Timestamp, std::vector<Detection>>;

// The dataset's ground truth, or none with a warning saying why (missing groundtruth.txt is no
// warning; a malformed one is, and the run goes on without evaluation).
std::vector<StampedPose> ReadRunGroundTruth(const RgbdDataset& dataset);

// A file of boxes per frame ('timestamp x y w h class score'): class ids are checked against the
// detector's class names (`system.detector.names_path`, else the default model's when it is
// found). Throws InputError naming the file and line.
DetectionsByStamp ReadRunDetections(const std::string& path, const SystemOptions& system);

// Warns (with counts) when the boxes of `path` match none or only some of the frames [first,
// last) of `dataset` (another sequence, stamps in another unit), or lie outside the image.
void WarnUnmatchedDetections(const std::string& path, const DetectionsByStamp& detections,
                             const PinholeCamera& camera, const RgbdDataset& dataset, size_t first,
                             size_t last);

// What a command says about a dataset before it runs on rgb entries [first, last), each as
// "dygslam COMMAND: warning: ..." on stderr (the run goes on; each is something to check): images
// in rgb/ or depth/ that the lists leave out, depth outside any sensor's range on most pixels, and
// a ground truth (when given) that does not cover the frames. Throws what reading a depth image
// throws.
void WarnAboutDataset(const std::string& command, const RgbdDataset& dataset, size_t first,
                      size_t last, double depth_map_factor, int width, int height,
                      const std::vector<StampedPose>* groundtruth);
// The ground truth of a run (ReadRunGroundTruth), after what `command` says before it runs
// (WarnAboutDataset; with boxes from `detections_path`, WarnUnmatchedDetections).
std::vector<StampedPose> ReadGroundTruthAndWarn(const std::string& command,
                                                const RunControllerOptions& options,
                                                const RgbdDataset& dataset,
                                                const std::string& detections_path);

// An OctoMap (.ot) a run continues: read once to check it. Throws InputError naming `option`
// and the file.
void CheckOctoMapToContinue(const std::string& option, const std::string& path);

// The files a run starts from or saves besides the dataset, as the command line gives them ("":
// not given).
struct RunInputFiles {
  std::string load_map;       // --load-map: the SLAM map to start from
  bool localization = false;  // --localization: track against it only
  std::string save_map;       // --save-map: the SLAM map written at the end
  std::string load_octomap;   // --load-octomap: the OctoMap to continue
  std::string detections;     // --detections: boxes per frame instead of the detector
};
// Checks each file before any work and sets it in `options` (system.load_map / localization,
// save_map, load_octomap, detections + use_detection_file); the loaded map is described on
// stdout. Throws UsageError for options that exclude each other, InputError naming the option
// and the file for a file that cannot be used.
void ReadRunInputFiles(const RunInputFiles& files, RunControllerOptions* options);

}  // namespace dygslam
