#include "core/place/vocabulary.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <numeric>

#include "core/io/file_util.h"

namespace dygslam {
namespace {

constexpr char kMagic[8] = {'D', 'Y', 'G', 'V', 'O', 'C', 'A', 'B'};
constexpr uint32_t kVersion = 1;
// Bytes per node in the file: descriptor 32, parent 4, first child 4, children 4, word 4,
// weight 4, level 1.
constexpr size_t kNodeBytes = 32 + 4 + 4 + 4 + 4 + 4 + 1;
constexpr size_t kHeaderBytes = 8 + 4 * 5;

uint64_t Fnv1a(const uint8_t* data, size_t size) {
  uint64_t h = 1469598103934665603ULL;
  for (size_t i = 0; i < size; ++i) {
    h ^= data[i];
    h *= 1099511628211ULL;
  }
  return h;
}

// splitmix64: a small deterministic generator (the same tree on every platform).
uint64_t NextRandom(uint64_t* state) {
  uint64_t z = (*state += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

// Bitwise majority of a set of descriptors (the Hamming-space "mean").
Descriptor Majority(const std::vector<const Descriptor*>& members) {
  std::array<int, 256> ones{};
  for (const Descriptor* d : members) {
    for (int w = 0; w < 4; ++w) {
      uint64_t bits = (*d)[w];
      while (bits) {
        const int b = __builtin_ctzll(bits);
        ones[w * 64 + b]++;
        bits &= bits - 1;
      }
    }
  }
  Descriptor out{};
  const size_t half = members.size() / 2;
  for (int i = 0; i < 256; ++i) {
    // Ties (even count, exactly half) give 0, as a strict majority.
    if (static_cast<size_t>(ones[i]) > half) out[i / 64] |= (uint64_t{1} << (i % 64));
  }
  return out;
}

template <typename T>
void Put(std::vector<uint8_t>* out, T value) {
  const auto* p = reinterpret_cast<const uint8_t*>(&value);
  out->insert(out->end(), p, p + sizeof(T));
}

template <typename T>
T Get(const uint8_t* data, size_t* offset) {
  T value;
  std::memcpy(&value, data + *offset, sizeof(T));
  *offset += sizeof(T);
  return value;
}

// k-means++ seeding with Hamming distances: up to k centres, each drawn with probability
// proportional to its squared distance from the nearest centre so far (fewer when the remaining
// descriptors all equal a centre).
std::vector<Descriptor> SeedCenters(const std::vector<const Descriptor*>& descriptors, int k,
                                    uint64_t* rng_state) {
  const size_t n = descriptors.size();
  std::vector<Descriptor> centers;
  centers.push_back(*descriptors[NextRandom(rng_state) % n]);
  std::vector<double> min_dist(n, std::numeric_limits<double>::max());
  while (static_cast<int>(centers.size()) < k) {
    double total = 0;
    for (size_t i = 0; i < n; ++i) {
      const double d = HammingDistance(*descriptors[i], centers.back());
      min_dist[i] = std::min(min_dist[i], d * d);
      total += min_dist[i];
    }
    if (total <= 0) break;  // all remaining descriptors equal a center
    const double target =
        total * (static_cast<double>(NextRandom(rng_state) >> 11) / 9007199254740992.0);
    double acc = 0;
    size_t pick = n - 1;
    for (size_t i = 0; i < n; ++i) {
      acc += min_dist[i];
      if (acc >= target && min_dist[i] > 0) {
        pick = i;
        break;
      }
    }
    centers.push_back(*descriptors[pick]);
  }
  return centers;
}

// k-medians in Hamming space from `centers` (bitwise majority as the centre), at most
// `max_iterations` rounds; the descriptors of each centre into `groups`, empty clusters dropped.
void ClusterDescriptors(const std::vector<const Descriptor*>& descriptors, int max_iterations,
                        std::vector<Descriptor>* centers,
                        std::vector<std::vector<const Descriptor*>>* groups) {
  const size_t n = descriptors.size();
  std::vector<int> assignment(n, -1);
  for (int it = 0; it < max_iterations; ++it) {
    bool changed = false;
    groups->assign(centers->size(), {});
    for (size_t i = 0; i < n; ++i) {
      int best = 0, best_d = 257;
      for (size_t c = 0; c < centers->size(); ++c) {
        const int d = HammingDistance(*descriptors[i], (*centers)[c]);
        if (d < best_d) {
          best_d = d;
          best = static_cast<int>(c);
        }
      }
      if (assignment[i] != best) {
        assignment[i] = best;
        changed = true;
      }
      (*groups)[best].push_back(descriptors[i]);
    }
    if (!changed && it > 0) break;
    for (size_t c = 0; c < centers->size(); ++c) {
      if (!(*groups)[c].empty()) (*centers)[c] = Majority((*groups)[c]);
    }
  }
  std::vector<Descriptor> kept_centers;
  std::vector<std::vector<const Descriptor*>> kept_groups;
  for (size_t c = 0; c < centers->size(); ++c) {
    if ((*groups)[c].empty()) continue;
    kept_centers.push_back((*centers)[c]);
    kept_groups.push_back(std::move((*groups)[c]));
  }
  centers->swap(kept_centers);
  groups->swap(kept_groups);
}

}  // namespace

void Vocabulary::BuildNode(uint32_t node, const std::vector<const Descriptor*>& descriptors,
                           const VocabularyOptions& options, uint64_t* rng_state) {
  const int level = nodes_[node].level;
  if (level >= options.depth || descriptors.empty()) return;
  const int k = options.branching;
  std::vector<Descriptor> centers;
  std::vector<std::vector<const Descriptor*>> groups;
  if (static_cast<int>(descriptors.size()) <= k) {
    // Few descriptors: each one is its own child (as DBoW2 does).
    for (const Descriptor* d : descriptors) {
      centers.push_back(*d);
      groups.push_back({d});
    }
  } else {
    centers = SeedCenters(descriptors, k, rng_state);
    ClusterDescriptors(descriptors, options.max_iterations, &centers, &groups);
  }
  const uint32_t first = static_cast<uint32_t>(nodes_.size());
  nodes_[node].first_child = first;
  nodes_[node].num_children = static_cast<uint32_t>(centers.size());
  for (const Descriptor& c : centers) {
    Node child;
    child.descriptor = c;
    child.parent = node;
    child.level = static_cast<uint8_t>(level + 1);
    nodes_.push_back(child);
  }
  for (size_t c = 0; c < centers.size(); ++c) {
    BuildNode(first + static_cast<uint32_t>(c), groups[c], options, rng_state);
  }
}

Vocabulary Vocabulary::Train(const std::vector<std::vector<Descriptor>>& images,
                             const VocabularyOptions& options) {
  options.Check();
  std::vector<const Descriptor*> all;
  for (const auto& image : images)
    for (const Descriptor& d : image) all.push_back(&d);
  if (all.empty()) throw InvalidOptions("Vocabulary::Train: no training descriptors");
  Vocabulary v;
  v.branching_ = options.branching;
  v.depth_ = options.depth;
  v.nodes_.push_back(Node{});
  uint64_t rng = options.seed;
  v.BuildNode(0, all, options, &rng);
  // Leaves (nodes without children) are the words, numbered in node order.
  for (uint32_t i = 1; i < v.nodes_.size(); ++i) {
    if (v.nodes_[i].num_children == 0) {
      v.nodes_[i].word = static_cast<int32_t>(v.word_nodes_.size());
      v.word_nodes_.push_back(i);
    }
  }
  // IDF: log(N / n_i), n_i = training images containing word i.
  std::vector<int> images_with(v.word_nodes_.size(), 0);
  std::vector<int64_t> last_image(v.word_nodes_.size(), -1);
  for (size_t img = 0; img < images.size(); ++img) {
    for (const Descriptor& d : images[img]) {
      const WordId w = v.Transform(d);
      if (last_image[w] != static_cast<int64_t>(img)) {
        last_image[w] = static_cast<int64_t>(img);
        images_with[w]++;
      }
    }
  }
  const double n = static_cast<double>(images.size());
  for (size_t w = 0; w < v.word_nodes_.size(); ++w) {
    v.nodes_[v.word_nodes_[w]].weight =
        images_with[w] > 0 ? static_cast<float>(std::log(n / images_with[w])) : 0.0f;
  }
  return v;
}

WordId Vocabulary::Transform(const Descriptor& descriptor, int level, NodeId* node_at_level) const {
  uint32_t node = 0;
  if (node_at_level && level <= 0) *node_at_level = 0;
  while (nodes_[node].num_children > 0) {
    const Node& parent = nodes_[node];
    uint32_t best = parent.first_child;
    int best_d = 257;
    for (uint32_t c = parent.first_child; c < parent.first_child + parent.num_children; ++c) {
      const int d = HammingDistance(descriptor, nodes_[c].descriptor);
      if (d < best_d) {
        best_d = d;
        best = c;
      }
    }
    node = best;
    if (node_at_level && nodes_[node].level <= level) *node_at_level = node;
  }
  return static_cast<WordId>(nodes_[node].word);
}

void Vocabulary::Transform(const std::vector<Descriptor>& descriptors, BowVector* bow,
                           FeatureVector* features, int direct_index_level) const {
  bow->clear();
  if (features) features->clear();
  if (empty()) return;
  for (size_t i = 0; i < descriptors.size(); ++i) {
    NodeId node = 0;
    const WordId w = Transform(descriptors[i], direct_index_level, &node);
    const double weight = WordWeight(w);
    if (weight > 0) (*bow)[w] += weight;  // TF (counted) x IDF
    if (features) (*features)[node].push_back(static_cast<int>(i));
  }
  double norm = 0;
  for (const auto& [w, value] : *bow) norm += std::abs(value);
  if (norm > 0)
    for (auto& [w, value] : *bow) value /= norm;
}

double Vocabulary::Score(const BowVector& a, const BowVector& b) {
  // For L1-normalised vectors, |a - b|_1 = 2 - sum over shared words of (|x| + |y| - |x - y|).
  double shared = 0;
  auto ia = a.begin();
  auto ib = b.begin();
  while (ia != a.end() && ib != b.end()) {
    if (ia->first < ib->first) {
      ia = a.lower_bound(ib->first);
    } else if (ib->first < ia->first) {
      ib = b.lower_bound(ia->first);
    } else {
      shared += std::abs(ia->second) + std::abs(ib->second) - std::abs(ia->second - ib->second);
      ++ia;
      ++ib;
    }
  }
  return 0.5 * shared;
}

std::vector<uint8_t> Vocabulary::Serialize() const {
  std::vector<uint8_t> out;
  out.reserve(kHeaderBytes + nodes_.size() * kNodeBytes + 8);
  out.insert(out.end(), kMagic, kMagic + 8);
  Put<uint32_t>(&out, kVersion);
  Put<uint32_t>(&out, static_cast<uint32_t>(branching_));
  Put<uint32_t>(&out, static_cast<uint32_t>(depth_));
  Put<uint32_t>(&out, static_cast<uint32_t>(nodes_.size()));
  Put<uint32_t>(&out, static_cast<uint32_t>(word_nodes_.size()));
  for (const Node& n : nodes_) {
    for (uint64_t w : n.descriptor) Put<uint64_t>(&out, w);
    Put<uint32_t>(&out, n.parent);
    Put<uint32_t>(&out, n.first_child);
    Put<uint32_t>(&out, n.num_children);
    Put<int32_t>(&out, n.word);
    Put<float>(&out, n.weight);
    Put<uint8_t>(&out, n.level);
  }
  return out;
}

uint64_t Vocabulary::Checksum() const {
  const auto bytes = Serialize();
  return Fnv1a(bytes.data(), bytes.size());
}

void Vocabulary::Save(const std::string& path) const {
  auto bytes = Serialize();
  Put<uint64_t>(&bytes, Fnv1a(bytes.data(), bytes.size()));
  WriteFileAtomically(path, std::string(bytes.begin(), bytes.end()));
}

Vocabulary Vocabulary::Load(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open vocabulary file (missing or unreadable)");
  const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                   std::istreambuf_iterator<char>());
  auto fail = [&](const std::string& what) -> InputError {
    return InputError(path, 0, "not a valid vocabulary file: " + what);
  };
  if (bytes.size() < kHeaderBytes + 8)
    throw fail("too short (" + std::to_string(bytes.size()) + " bytes)");
  if (std::memcmp(bytes.data(), kMagic, 8) != 0) throw fail("bad magic (not a dygslam vocabulary)");
  size_t off = 8;
  const uint32_t version = Get<uint32_t>(bytes.data(), &off);
  if (version != kVersion)
    throw fail("version " + std::to_string(version) + ", this build reads " +
               std::to_string(kVersion));
  const uint32_t branching = Get<uint32_t>(bytes.data(), &off);
  const uint32_t depth = Get<uint32_t>(bytes.data(), &off);
  const uint32_t num_nodes = Get<uint32_t>(bytes.data(), &off);
  const uint32_t num_words = Get<uint32_t>(bytes.data(), &off);
  const size_t expected = kHeaderBytes + static_cast<size_t>(num_nodes) * kNodeBytes + 8;
  if (bytes.size() != expected)
    throw fail("size " + std::to_string(bytes.size()) + " bytes, header says " +
               std::to_string(expected) + " (truncated or corrupt)");
  size_t check_off = bytes.size() - 8;
  const uint64_t stored = Get<uint64_t>(bytes.data(), &check_off);
  if (stored != Fnv1a(bytes.data(), bytes.size() - 8)) throw fail("checksum mismatch (corrupt)");
  if (branching < 2 || branching > 64 || depth < 1 || depth > 8 || num_nodes < 2)
    throw fail("bad shape (branching " + std::to_string(branching) + ", depth " +
               std::to_string(depth) + ")");
  Vocabulary v;
  v.branching_ = static_cast<int>(branching);
  v.depth_ = static_cast<int>(depth);
  v.nodes_.resize(num_nodes);
  for (Node& n : v.nodes_) {
    for (uint64_t& w : n.descriptor) w = Get<uint64_t>(bytes.data(), &off);
    n.parent = Get<uint32_t>(bytes.data(), &off);
    n.first_child = Get<uint32_t>(bytes.data(), &off);
    n.num_children = Get<uint32_t>(bytes.data(), &off);
    n.word = Get<int32_t>(bytes.data(), &off);
    n.weight = Get<float>(bytes.data(), &off);
    n.level = Get<uint8_t>(bytes.data(), &off);
  }
  // Structure: children in range and pointing back, leaves numbered 0..num_words-1.
  v.word_nodes_.assign(num_words, 0);
  std::vector<uint8_t> seen(num_words, 0);
  for (uint32_t i = 0; i < num_nodes; ++i) {
    const Node& n = v.nodes_[i];
    if (n.num_children > branching ||
        (n.num_children > 0 && (n.first_child <= i || n.first_child + n.num_children > num_nodes)))
      throw fail("node " + std::to_string(i) + " has bad children");
    for (uint32_t c = n.first_child; c < n.first_child + n.num_children; ++c) {
      if (v.nodes_[c].parent != i || v.nodes_[c].level != n.level + 1)
        throw fail("node " + std::to_string(c) + " has a bad parent or level");
    }
    if (i > 0 && n.num_children == 0) {
      if (n.word < 0 || static_cast<uint32_t>(n.word) >= num_words || seen[n.word] ||
          !std::isfinite(n.weight) || n.weight < 0)
        throw fail("leaf " + std::to_string(i) + " has a bad word id or weight");
      seen[n.word] = 1;
      v.word_nodes_[n.word] = i;
    }
  }
  if (v.nodes_[0].num_children == 0 ||
      std::count(seen.begin(), seen.end(), uint8_t{1}) != static_cast<long>(num_words))
    throw fail("word count does not match the leaves");
  return v;
}

}  // namespace dygslam
