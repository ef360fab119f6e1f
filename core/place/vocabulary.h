// Bag of binary words: a vocabulary tree over 256-bit ORB descriptors (hierarchical k-majority
// clustering, like k-medians for Hamming space), TF-IDF word weights and the L1 similarity score.
// A descriptor descends the tree (nearest child by Hamming distance at each level) to a leaf, its
// word. An image becomes a BowVector (word -> weight, L1-normalised) and, for matching, a
// FeatureVector (direct index: node at a chosen level -> indices of the image's features under
// it), so two images are matched only within the same node instead of all against all.
//
// File format (binary, little-endian, see vocabulary.cc): magic, version, shape, nodes, and a
// 64-bit FNV-1a checksum of everything before it. Load rejects a missing, truncated, corrupt or
// foreign file with an InputError naming the file.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/base/descriptor.h"
#include "core/base/error.h"

namespace dygslam {

using WordId = uint32_t;
using NodeId = uint32_t;
// word -> weight; L1 norm 1 once built by Vocabulary::Transform.
using BowVector = std::map<WordId, double>;
// node (at the direct-index level) -> feature indices of the image, ascending.
using FeatureVector = std::map<NodeId, std::vector<int>>;

struct VocabularyOptions {
  int branching = 10;       // children per node (k)
  int depth = 4;            // levels below the root (L): up to k^L words
  int max_iterations = 12;  // k-majority rounds per node
  uint64_t seed = 1;        // k-means++ seeding
  void Check() const {
    DYGSLAM_CHECK_OPTION(branching >= 2 && branching <= 64, "Vocabulary.branching");
    DYGSLAM_CHECK_OPTION(depth >= 1 && depth <= 8, "Vocabulary.depth");
    DYGSLAM_CHECK_OPTION(max_iterations >= 1, "Vocabulary.max_iterations");
  }
};

// The first bytes of every vocabulary file.
inline constexpr char kVocabularyFileSignature[] = "DYGVOCAB";

class Vocabulary {
 public:
  Vocabulary() = default;

  // Builds the tree from the descriptors of training images (one vector per image; the image
  // count gives the IDF weights). Deterministic for given input and options.
  static Vocabulary Train(const std::vector<std::vector<Descriptor>>& images,
                          const VocabularyOptions& options);
  // Throws InputError naming `path` (missing, unreadable, truncated, bad magic/version/checksum,
  // inconsistent tree).
  static Vocabulary Load(const std::string& path);
  // Throws InputError naming `path` when it cannot be written (written atomically).
  void Save(const std::string& path) const;

  bool empty() const { return word_nodes_.empty(); }
  size_t NumWords() const { return word_nodes_.size(); }
  size_t NumNodes() const { return nodes_.size(); }
  int branching() const { return branching_; }
  int depth() const { return depth_; }
  double WordWeight(WordId word) const { return nodes_[word_nodes_[word]].weight; }

  // The word of one descriptor; *node_at_level (optional) = its ancestor at `level` (0 = root,
  // depth() = the leaf itself; deeper levels are clamped to the leaf).
  WordId Transform(const Descriptor& descriptor, int level = 0,
                   NodeId* node_at_level = nullptr) const;
  // BoW vector (TF-IDF, L1-normalised) and direct index at `direct_index_level` of a feature set.
  void Transform(const std::vector<Descriptor>& descriptors, BowVector* bow,
                 FeatureVector* features = nullptr, int direct_index_level = 2) const;

  // L1 similarity of two L1-normalised vectors: 1 - |a - b|_1 / 2, in [0, 1].
  static double Score(const BowVector& a, const BowVector& b);

  // Checksum of the tree (the same value Save writes), to tell vocabularies apart in logs.
  uint64_t Checksum() const;

 private:
  struct Node {
    Descriptor descriptor{};
    uint32_t parent = 0;
    uint32_t first_child = 0;  // children are stored contiguously
    uint32_t num_children = 0;
    int32_t word = -1;  // leaf: word id
    float weight = 0;   // leaf: IDF weight
    uint8_t level = 0;
  };
  std::vector<uint8_t> Serialize() const;
  void BuildNode(uint32_t node, const std::vector<const Descriptor*>& descriptors,
                 const VocabularyOptions& options, uint64_t* rng_state);

  int branching_ = 0, depth_ = 0;
  std::vector<Node> nodes_;  // nodes_[0] = root
  std::vector<uint32_t> word_nodes_;
};

}  // namespace dygslam
