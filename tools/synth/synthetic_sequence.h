// Writes a synthetic sequence (see synthetic_scene.h) as a TUM RGB-D style folder:
//   rgb/<stamp>.png     8-bit BGR colour            rgb.txt    "timestamp rgb/<stamp>.png"
//   depth/<stamp>.png   16-bit, value / 5000 = m    depth.txt  "timestamp depth/<stamp>.png"
//                       (depth stamps are offset a few ms from the rgb stamps)
//   mask/<stamp>.png    8-bit, 255 = moving object  mask.txt   "timestamp mask/<stamp>.png"
//   groundtruth.txt     "timestamp tx ty tz qx qy qz qw" (world_from_cam) at the rgb stamps
//   detections.txt      "timestamp x y w h class_id score" (class 0 = person), one per box
//   objects.txt         "timestamp object_id tx ty tz qx qy qz qw size_x size_y size_z"
//                       (world_from_object, object centre; one line per present object and frame)
//   camera.yaml         ORB-SLAM2 settings (Camera.*, DepthMapFactor, ORBextractor.*)
// Every file is written atomically (temporary file + rename).
#pragma once

#include <functional>
#include <string>

#include "tools/synth/synthetic_scene.h"

namespace dygslam {

// Called after each written frame with (frames done, total).
using SyntheticProgress = std::function<void(int, int)>;

// Creates `directory` (and parents) if needed and writes the sequence into it. Throws InputError
// naming the path when a file cannot be written, InvalidOptions for bad options.
void WriteSyntheticSequence(const std::string& directory, const SyntheticOptions& options,
                            const SyntheticProgress& progress = {});

// The camera.yaml text for these options (ORB-SLAM2 key names, OpenCV "%YAML:1.0" header).
std::string SyntheticCameraYaml(const SyntheticOptions& options);

}  // namespace dygslam
