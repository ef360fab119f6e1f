#include "tools/vocab/synthetic_training.h"

#include <opencv2/imgproc.hpp>

#include "tools/synth/synthetic_scene.h"

namespace dygslam {

std::vector<std::vector<Descriptor>> SyntheticTrainingDescriptors(
    const SyntheticTrainingOptions& options, const std::function<void(int, int)>& progress) {
  options.Check();
  const OrbExtractor extractor(options.orb);
  std::vector<std::vector<Descriptor>> images;
  const int total = options.num_scenes * options.frames_per_scene;
  for (int s = 0; s < options.num_scenes; ++s) {
    SyntheticOptions scene_options;
    scene_options.seed = options.first_seed + static_cast<uint64_t>(s);
    scene_options.num_moving_objects = options.moving_objects;
    scene_options.num_frames = options.frames_per_scene * options.frame_stride;
    scene_options.supersampling = 1;
    const SyntheticScene scene(scene_options);
    for (int f = 0; f < options.frames_per_scene; ++f) {
      const SyntheticFrame frame = scene.RenderFrame(f * options.frame_stride);
      cv::Mat gray;
      cv::cvtColor(frame.rgb, gray, cv::COLOR_BGR2GRAY);
      images.push_back(extractor.Extract(gray).descriptors);
      if (progress) progress(static_cast<int>(images.size()), total);
    }
  }
  return images;
}

}  // namespace dygslam
