// Relocalization time per attempt vs map size: BoW index (candidates from the inverted index,
// direct-index matching) against brute force (every keyframe matched), on a keyframe map made
// from a generated sequence (tests/slam/synthetic_map.h). The query frames come 40 frames after
// a keyframe (the camera jumped 40 frames while tracking was lost) and are rendered with colour
// noise (their features differ from any keyframe's). Not a test: BENCHMARKS.md gets its output.
//   relocalization_benchmark [--keyframes 50,500] [--queries 15] [--vocabulary FILE]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <sstream>
#include <string>
#include <vector>

#include "core/slam/tracking/relocalization.h"
#include "tests/slam/synthetic_map.h"

using namespace dygslam;

namespace {

double ThreadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<int> sizes = {50, 500};
  int queries = 15;
  std::string vocabulary_path = std::string(DYGSLAM_SOURCE_DIR) + "/config/vocabulary.dygvoc";
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string key = argv[i], value = argv[i + 1];
    if (key == "--keyframes") {
      sizes.clear();
      std::stringstream ss(value);
      std::string item;
      while (std::getline(ss, item, ',')) sizes.push_back(std::atoi(item.c_str()));
    } else if (key == "--queries") {
      queries = std::atoi(value.c_str());
    } else if (key == "--vocabulary") {
      vocabulary_path = value;
    } else {
      std::fprintf(stderr, "usage: %s [--keyframes 50,500] [--queries 15] [--vocabulary FILE]\n",
                   argv[0]);
      return 2;
    }
  }
  const Vocabulary vocabulary = Vocabulary::Load(vocabulary_path);
  const OrbExtractor extractor{OrbExtractorOptions{}};
  TrackingOptions options;
  const Matcher matcher(options.matcher);
  constexpr int kStride = 2, kJump = 40;
  std::printf(
      "keyframes | method | median wall ms/attempt | p90 wall ms | median CPU ms/attempt | "
      "relocalized | median error (m)\n");
  for (int n : sizes) {
    SyntheticOptions synth;
    synth.seed = 5;
    synth.num_moving_objects = 0;
    synth.supersampling = 1;
    synth.num_frames = n * kStride + kJump + 2;
    const SyntheticScene scene(synth);
    testing::SyntheticMap map;
    testing::BuildSyntheticMap(scene, n, kStride, vocabulary, extractor, &map);
    SyntheticOptions noisy = synth;
    noisy.rgb_noise_sigma = 3.0;
    const SyntheticScene noisy_scene(noisy);
    // Query frames spread over the mapped path: keyframe frame + 40 + 1 (never a keyframe).
    std::vector<int> query_frames;
    const int last = (n - 1) * kStride;
    for (int q = 0; q < queries; ++q) {
      const int base = static_cast<int>(static_cast<double>(q) / std::max(1, queries - 1) *
                                        std::max(0, last - kJump - 1));
      query_frames.push_back(std::min(base + kJump + 1, last - 1));
    }
    std::vector<Frame> frames;
    for (int f : query_frames)
      frames.push_back(testing::MakeSyntheticFrame(noisy_scene, noisy_scene.RenderFrame(f),
                                                   100000 + f, extractor, map.geometry));
    for (int method = 0; method < 2; ++method) {
      const bool bow = method == 0;
      std::vector<double> ms, cpu, errors;
      int ok = 0;
      std::lock_guard<std::mutex> lock(map.map->mutex());
      for (size_t q = 0; q < frames.size(); ++q) {
        Frame frame = frames[q];  // fresh copy: no BoW computed yet
        const auto t0 = std::chrono::steady_clock::now();
        const double c0 = ThreadCpuMs();
        const RelocalizationResult r =
            RelocalizeFrame(frame, *map.map, bow ? &map.database : nullptr,
                            bow ? &vocabulary : nullptr, matcher, options);
        ms.push_back(
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                .count());
        cpu.push_back(ThreadCpuMs() - c0);
        if (r.ok) {
          ++ok;
          const Eigen::Vector3d c = frame.CameraCenter();
          errors.push_back((c - scene.WorldFromCam(query_frames[q]).translation).norm());
        }
      }
      std::vector<double> sorted = ms;
      std::sort(sorted.begin(), sorted.end());
      std::printf("%9d | %-11s | %8.2f | %8.2f | %8.2f | %d/%zu | %.4f\n", n,
                  bow ? "BoW index" : "brute force", Median(ms),
                  sorted[static_cast<size_t>(0.9 * (sorted.size() - 1))], Median(cpu), ok,
                  frames.size(), Median(errors));
      std::fflush(stdout);
    }
  }
  return 0;
}
