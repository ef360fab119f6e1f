// Training data for the vocabulary that is not an evaluation sequence: frames rendered by the
// synthetic generator (tools/synth) from several scene seeds (each seed gives other procedural
// textures and furniture), with the ORB features the tracker uses.
#pragma once

#include <functional>
#include <vector>

#include "core/place/vocabulary.h"
#include "core/slam/feature/orb_extractor.h"

namespace dygslam {

struct SyntheticTrainingOptions {
  int num_scenes = 12;         // scene seeds first_seed .. first_seed + num_scenes - 1
  uint64_t first_seed = 1000;  // far from the seeds tests and benchmarks use
  int frames_per_scene = 25;   // spread over a 40 s path
  int frame_stride = 48;       // rendered frame indices 0, stride, 2*stride, ...
  int moving_objects = 2;      // people in the training frames (their texture too)
  OrbExtractorOptions orb;     // as the tracker extracts them
  void Check() const {
    DYGSLAM_CHECK_OPTION(num_scenes >= 1, "SyntheticTraining.num_scenes");
    DYGSLAM_CHECK_OPTION(frames_per_scene >= 1, "SyntheticTraining.frames_per_scene");
    DYGSLAM_CHECK_OPTION(frame_stride >= 1, "SyntheticTraining.frame_stride");
    orb.Check();
  }
};

// Descriptors per rendered training image. progress(done, total) after each image.
std::vector<std::vector<Descriptor>> SyntheticTrainingDescriptors(
    const SyntheticTrainingOptions& options, const std::function<void(int, int)>& progress = {});

}  // namespace dygslam
