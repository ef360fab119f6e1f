// Map file load time and size. Not a test: BENCHMARKS.md gets its output.
//   map_file_benchmark [--keyframes 50] [--runs 7] [--map FILE --config SETTINGS.yaml]
// 1. A keyframe map made from a generated sequence (tests/slam/synthetic_map.h: every feature
//    with depth a map point, BoW vectors): saved, then loaded --runs times (LoadMapFile: read,
//    checksum, decode, rebuild). Baseline measured in the same run: reading the file's bytes.
// 2. With --map/--config: a map saved by `dygslam run --save-map`, loaded through CheckMapFile
//    (settings, vocabulary, decode); baseline: loading the vocabulary alone.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "core/config/settings.h"
#include "core/slam/map/map_file.h"
#include "core/system/system.h"
#include "run/settings_table.h"
#include "run/system_config.h"
#include "tests/slam/synthetic_map.h"

using namespace dygslam;

namespace {

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

template <class F>
double Ms(F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int main(int argc, char** argv) {
  int keyframes = 50, runs = 7;
  std::string map_path, config_path;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string key = argv[i], value = argv[i + 1];
    if (key == "--keyframes") {
      keyframes = std::atoi(value.c_str());
    } else if (key == "--runs") {
      runs = std::atoi(value.c_str());
    } else if (key == "--map") {
      map_path = value;
    } else if (key == "--config") {
      config_path = value;
    } else {
      std::fprintf(stderr, "usage: %s [--keyframes 50] [--runs 7] [--map FILE --config YAML]\n",
                   argv[0]);
      return 2;
    }
  }
  const std::string vocabulary_path = std::string(DYGSLAM_SOURCE_DIR) + "/config/vocabulary.dygvoc";
  const Vocabulary vocabulary = Vocabulary::Load(vocabulary_path);
  const OrbExtractor extractor{OrbExtractorOptions{}};
  SyntheticOptions synth;
  synth.num_frames = keyframes * 3;
  synth.num_moving_objects = 0;
  synth.supersampling = 1;
  const SyntheticScene scene(synth);
  testing::SyntheticMap built;
  testing::BuildSyntheticMap(scene, keyframes, 3, vocabulary, extractor, &built);
  const MapFileSettings settings =
      MapFileSettings::Of(*built.geometry, extractor.options().scale_factor, vocabulary.Checksum());
  const std::string path = "/tmp/map_file_benchmark.dygmap";
  std::vector<double> save_ms, load_ms, read_ms;
  MapFileInfo info;
  for (int r = 0; r < runs; ++r) {
    save_ms.push_back(Ms([&] { info = SaveMapFile(path, *built.map, settings); }));
    read_ms.push_back(Ms([&] {
      std::ifstream in(path, std::ios::binary);
      const std::string bytes((std::istreambuf_iterator<char>(in)),
                              std::istreambuf_iterator<char>());
      if (bytes.size() != info.bytes) std::abort();
    }));
    load_ms.push_back(Ms([&] {
      const LoadedMap loaded = LoadMapFile(path, settings, built.geometry);
      if (loaded.info.keyframes != static_cast<size_t>(keyframes)) std::abort();
    }));
  }
  std::printf("generated map: %d keyframes, %zu map points, %zu bytes (%.0f bytes per keyframe)\n",
              keyframes, info.map_points, info.bytes, double(info.bytes) / keyframes);
  std::printf(
      "median of %d runs: load %.1f ms, save %.1f ms; baseline read of the bytes %.1f ms "
      "(load / read %.1fx)\n",
      runs, Median(load_ms), Median(save_ms), Median(read_ms),
      Median(load_ms) / std::max(Median(read_ms), 1e-9));
  std::remove(path.c_str());

  if (!map_path.empty()) {
    const Settings parsed = LoadSettings(config_path, SettingsReadOptions{});
    const SystemOptions options = SystemOptionsFromSettings(parsed);
    std::vector<double> check_ms, vocabulary_ms;
    MapFileInfo real;
    for (int r = 0; r < runs; ++r) {
      vocabulary_ms.push_back(
          Ms([&] { Vocabulary::Load(options.loop_closing.vocabulary).NumWords(); }));
      check_ms.push_back(Ms([&] { real = CheckMapFile(map_path, options); }));
    }
    const double kf = std::max<double>(1, real.keyframes);
    std::printf("%s: %zu keyframes, %zu map points, %zu bytes (%.0f bytes per keyframe)\n",
                map_path.c_str(), real.keyframes, real.map_points, real.bytes, real.bytes / kf);
    std::printf(
        "median of %d runs: load with settings and vocabulary %.1f ms; baseline "
        "vocabulary load alone %.1f ms (map part %.1f ms)\n",
        runs, Median(check_ms), Median(vocabulary_ms), Median(check_ms) - Median(vocabulary_ms));
  }
  return 0;
}
