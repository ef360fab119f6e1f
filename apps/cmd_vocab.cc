// dygslam vocab OUT_FILE [--scenes N] [--frames-per-scene M] [--branching K] [--depth L] ...
// Trains the place-recognition vocabulary (core/place/vocabulary.h) on frames rendered by the
// synthetic generator (never on an evaluation sequence) and writes it.
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "apps/command.h"
#include "core/base/error.h"
#include "core/io/file_util.h"
#include "core/place/vocabulary.h"
#include "tools/vocab/synthetic_training.h"

namespace dygslam::cli {
namespace {

int RunVocab(const std::vector<std::string>& args) {
  ArgParser p("vocab",
              "OUT_FILE [--scenes N] [--frames-per-scene M] [--branching K] [--depth L]\n"
              "              [--first-seed S] [--quiet]",
              R"(Trains the bag-of-words vocabulary for relocalization and loop closing on ORB
features of frames rendered by the synthetic generator (scene seeds S .. S+N-1,
each with its own procedural textures; never the evaluation sequences), by
hierarchical k-majority clustering (K children per node, L levels) with TF-IDF
weights, and writes the binary vocabulary file (checksummed). The same options
give a byte-identical file. The repository ships config/vocabulary.dygvoc made
with the defaults.)");
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
  if (!p.GetInt("scenes", 1, 10000, &training.num_scenes) ||
      !p.GetInt("frames-per-scene", 1, 10000, &training.frames_per_scene) ||
      !p.GetInt("branching", 2, 64, &vocabulary.branching) ||
      !p.GetInt("depth", 1, 8, &vocabulary.depth) ||
      !p.GetInt("first-seed", 0, 1000000000, &first_seed))
    return p.exit_code();
  training.first_seed = static_cast<uint64_t>(first_seed);
  // An earlier vocabulary is replaced; any other file given by mistake is not.
  if (const std::string foreign =
          FindForeignFileAtOutput({"OUT_FILE", p.Positional("OUT_FILE")}, kVocabularyFileSignature,
                                  "a dygslam vocabulary file");
      !foreign.empty())
    return p.UsageError(foreign);
  PinFolderOfOutput(p.Positional("OUT_FILE"));  // replaced while training: not written through
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
