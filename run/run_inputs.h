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

// An OctoMap (.ot) a run continues: read once to check it. Throws InputError naming `option`
// and the file.
void CheckOctoMapToContinue(const std::string& option, const std::string& path);

}  // namespace dygslam
