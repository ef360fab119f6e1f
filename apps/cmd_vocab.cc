// dygslam vocab OUT_FILE [--scenes N] [--frames-per-scene M] [--branching K] [--depth L] ...
// Trains the place-recognition vocabulary (core/place/vocabulary.h) on frames rendered by the
// synthetic generator (never on an evaluation sequence) and writes it.
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "apps/command.h"
#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/place/synthetic_training.h"
#include "core/place/vocabulary.h"

namespace dygslam::cli {
namespace {

bool ParseCount(const std::string& text, int min_value, int max_value, int* value) {
  if (text.empty() || text.size() > 9) return false;
  int v = 0;
  for (char c : text) {
    if (c < '0' || c > '9') return false;
    v = v * 10 + (c - '0');
  }
  if (v < min_value || v > max_value) return false;
  *value = v;
  return true;
}

int RunVocab(const std::vector<std::string>& args) {
  ArgParser p("vocab",
              "OUT_FILE [--scenes N] [--frames-per-scene M] [--branching K] [--depth L]\n"
              "              [--first-seed S] [--quiet]",
              "Trains the bag-of-words vocabulary for relocalization and loop closing on ORB\n"
              "features of frames rendered by the synthetic generator (scene seeds S .. S+N-1,\n"
              "each with its own procedural textures; never the evaluation sequences), by\n"
              "hierarchical k-majority clustering (K children per node, L levels) with TF-IDF\n"
              "weights, and writes the binary vocabulary file (checksummed). The same options\n"
              "give a byte-identical file. The repository ships config/vocabulary.dygvoc made\n"
              "with the defaults.");
  p.AddPositional("OUT_FILE", "vocabulary file to write (e.g. config/vocabulary.dygvoc)");
  p.AddOption("scenes", "N", "synthetic scenes (seeds)", "12");
  p.AddOption("frames-per-scene", "M", "frames rendered per scene (every 48th of its path)", "25");
  p.AddOption("branching", "K", "children per node (2..64)", "10");
  p.AddOption("depth", "L", "levels (1..8); up to K^L words", "4");
  p.AddOption("first-seed", "S", "first scene seed", "1000");
  p.AddFlag("quiet", "no progress line");
  if (!p.Parse(args)) return p.exit_code();

  SyntheticTrainingOptions training;
  VocabularyOptions vocabulary;
  int first_seed = 0;
  if (!ParseCount(p.Get("scenes"), 1, 10000, &training.num_scenes))
    return p.UsageError("--scenes: expected an integer in 1..10000, got '" +
                        EchoValue(p.Get("scenes")) + "'");
  if (!ParseCount(p.Get("frames-per-scene"), 1, 10000, &training.frames_per_scene))
    return p.UsageError("--frames-per-scene: expected an integer in 1..10000, got '" +
                        EchoValue(p.Get("frames-per-scene")) + "'");
  if (!ParseCount(p.Get("branching"), 2, 64, &vocabulary.branching))
    return p.UsageError("--branching: expected an integer in 2..64, got '" +
                        EchoValue(p.Get("branching")) + "'");
  if (!ParseCount(p.Get("depth"), 1, 8, &vocabulary.depth))
    return p.UsageError("--depth: expected an integer in 1..8, got '" + EchoValue(p.Get("depth")) +
                        "'");
  if (!ParseCount(p.Get("first-seed"), 0, 1000000000, &first_seed))
    return p.UsageError("--first-seed: expected a non-negative integer, got '" +
                        EchoValue(p.Get("first-seed")) + "'");
  training.first_seed = static_cast<uint64_t>(first_seed);
  const bool quiet = p.Flag("quiet");

  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  const auto images = SyntheticTrainingDescriptors(training, [&](int done, int total) {
    if (quiet) return;
    std::fprintf(stderr, "\rvocab: rendered and extracted %d/%d images", done, total);
    std::fflush(stderr);
  });
  if (!quiet) std::fprintf(stderr, "\nvocab: clustering...\n");
  size_t descriptors = 0;
  for (const auto& image : images) descriptors += image.size();
  const Vocabulary v = Vocabulary::Train(images, vocabulary);
  v.Save(p.Positional("OUT_FILE"));
  std::printf(
      "wrote %s: %zu words, %zu nodes (k=%d, L=%d) from %zu descriptors of %zu synthetic images "
      "(seeds %d..%d), checksum %016llx, %.1f s\n",
      p.Positional("OUT_FILE").c_str(), v.NumWords(), v.NumNodes(), v.branching(), v.depth(),
      descriptors, images.size(), first_seed, first_seed + training.num_scenes - 1,
      static_cast<unsigned long long>(v.Checksum()), elapsed());
  return 0;
}

const CommandRegistrar kRegistrar({"vocab", "train the place-recognition vocabulary", RunVocab});

}  // namespace
}  // namespace dygslam::cli
