#include "core/slam/feature/orb_extractor.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <queue>

#ifdef __SSE2__
#include <emmintrin.h>
#endif

namespace dygslam {
namespace {

constexpr int kPatchRadius = 15;  // circular patch for orientation and descriptor (31 px diameter)
constexpr int kBorder = kPatchRadius + 1;
constexpr int kCellSize = 30;  // FAST threshold fallback cell size (pixels at each level)

// Standard normal samples from a fixed-seed 64-bit LCG + Box-Muller: identical on every platform.
class PatternRng {
 public:
  explicit PatternRng(uint64_t seed) : state_(seed) {}
  double Uniform() {
    state_ = state_ * 6364136223846793005ULL + 1442695040888963407ULL;
    return (static_cast<double>(state_ >> 11) + 0.5) * (1.0 / 9007199254740992.0);
  }
  double Normal() {
    const double u1 = Uniform(), u2 = Uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
  }

 private:
  uint64_t state_;
};

// The pattern's 512 test points (p0, q0, p1, q1, ...) as coordinate arrays.
struct PatternPoints {
  alignas(16) float x[512];
  alignas(16) float y[512];
};

const PatternPoints& PatternAsArrays() {
  static const PatternPoints points = [] {
    PatternPoints p{};
    const auto& pattern = OrbExtractor::Pattern();
    for (int bit = 0; bit < 256; ++bit) {
      for (int k = 0; k < 2; ++k) {
        p.x[2 * bit + k] = pattern[bit][k].x;
        p.y[2 * bit + k] = pattern[bit][k].y;
      }
    }
    return p;
  }();
  return points;
}

// offsets[i] = round(sa x + ca y) * step + round(ca x - sa y) for every test point: the same
// float operations and round-to-nearest-even as cvRound of the scalar expressions, so the
// descriptors are bit-identical to computing them one test at a time.
void RotatedOffsets(const PatternPoints& points, float ca, float sa, int step, int* offsets) {
#ifdef __SSE2__
  const __m128 c = _mm_set1_ps(ca), s = _mm_set1_ps(sa);
  alignas(16) int rows[4], cols[4];
  for (int i = 0; i < 512; i += 4) {
    const __m128 x = _mm_load_ps(points.x + i), y = _mm_load_ps(points.y + i);
    const __m128i row = _mm_cvtps_epi32(_mm_add_ps(_mm_mul_ps(s, x), _mm_mul_ps(c, y)));
    const __m128i col = _mm_cvtps_epi32(_mm_sub_ps(_mm_mul_ps(c, x), _mm_mul_ps(s, y)));
    _mm_store_si128(reinterpret_cast<__m128i*>(rows), row);
    _mm_store_si128(reinterpret_cast<__m128i*>(cols), col);
    for (int k = 0; k < 4; ++k) offsets[i + k] = rows[k] * step + cols[k];
  }
#else
  for (int i = 0; i < 512; ++i) {
    offsets[i] = cvRound(sa * points.x[i] + ca * points.y[i]) * step +
                 cvRound(ca * points.x[i] - sa * points.y[i]);
  }
#endif
}

}  // namespace

const std::vector<std::array<cv::Point2f, 2>>& OrbExtractor::Pattern() {
  // BRIEF's isotropic Gaussian sampling (sigma = patch size / 5) restricted to a disk of radius 13
  // so that every rotated test point stays inside the radius-15 patch. Pairs that are too close
  // (< 2 px) carry little information and are re-drawn.
  static const std::vector<std::array<cv::Point2f, 2>> pattern = [] {
    std::vector<std::array<cv::Point2f, 2>> p;
    PatternRng rng(0x0D1C5EEDULL);
    const double sigma = 31.0 / 5.0;
    auto draw = [&]() {
      while (true) {
        const double x = rng.Normal() * sigma, y = rng.Normal() * sigma;
        if (x * x + y * y <= 13.0 * 13.0) return cv::Point2f(float(x), float(y));
      }
    };
    while (p.size() < 256) {
      const cv::Point2f a = draw(), b = draw();
      if (cv::norm(a - b) < 2.0) continue;
      p.push_back({a, b});
    }
    return p;
  }();
  return pattern;
}

cv::Mat OrbFeatures::DescriptorMatrix() const {
  cv::Mat m(static_cast<int>(descriptors.size()), 32, CV_8UC1);
  for (size_t i = 0; i < descriptors.size(); ++i) {
    std::memcpy(m.ptr<uint8_t>(static_cast<int>(i)), descriptors[i].data(), 32);
  }
  return m;
}

OrbExtractor::OrbExtractor(const OrbExtractorOptions& options) : options_(options) {
  options_.Check();
  const int levels = options_.num_levels;
  scales_.resize(levels);
  sigma2_.resize(levels);
  for (int l = 0; l < levels; ++l) {
    scales_[l] = std::pow(options_.scale_factor, l);
    sigma2_[l] = scales_[l] * scales_[l];
  }
  // Row half-widths of the circular patch, symmetric by construction.
  umax_.resize(kPatchRadius + 1);
  for (int v = 0; v <= kPatchRadius; ++v) {
    umax_[v] = static_cast<int>(std::floor(std::sqrt(kPatchRadius * kPatchRadius + 0.5 - v * v)));
  }
}

// Features per level decrease geometrically with the level's area ratio (1/s per level).
std::vector<int> OrbExtractor::FeaturesPerLevel(int num_features) const {
  const int levels = options_.num_levels;
  const double inv = 1.0 / options_.scale_factor;
  double per_level = num_features * (1 - inv) / (1 - std::pow(inv, levels));
  std::vector<int> counts(levels);
  int assigned = 0;
  for (int l = 0; l < levels - 1; ++l) {
    counts[l] = static_cast<int>(std::lround(per_level));
    assigned += counts[l];
    per_level *= inv;
  }
  counts[levels - 1] = std::max(num_features - assigned, 0);
  return counts;
}

void OrbExtractor::DistributeQuadtree(std::vector<cv::KeyPoint>& candidates, const cv::Rect& area,
                                      int target, std::vector<cv::KeyPoint>* kept) const {
  if (candidates.empty() || target <= 0) return;
  struct Node {
    float x0, y0, x1, y1;
    std::vector<int> members;
  };
  // Start with roughly square nodes covering the area.
  const int roots = std::max(1, static_cast<int>(std::lround(double(area.width) / area.height)));
  std::vector<Node> nodes;
  const float root_w = float(area.width) / roots;
  for (int r = 0; r < roots; ++r) {
    nodes.push_back({area.x + r * root_w,
                     float(area.y),
                     area.x + (r + 1) * root_w,
                     float(area.y + area.height),
                     {}});
  }
  for (int i = 0; i < static_cast<int>(candidates.size()); ++i) {
    const int r = std::min(roots - 1, static_cast<int>((candidates[i].pt.x - area.x) / root_w));
    nodes[std::max(r, 0)].members.push_back(i);
  }
  nodes.erase(
      std::remove_if(nodes.begin(), nodes.end(), [](const Node& n) { return n.members.empty(); }),
      nodes.end());
  // Split the most populated node until there are enough nodes or nothing can be split.
  auto cmp = [&](int a, int b) {
    if (nodes[a].members.size() != nodes[b].members.size())
      return nodes[a].members.size() < nodes[b].members.size();
    return a > b;  // deterministic tie-break
  };
  std::priority_queue<int, std::vector<int>, decltype(cmp)> queue(cmp);
  std::vector<bool> alive(nodes.size(), true);
  for (int i = 0; i < static_cast<int>(nodes.size()); ++i) queue.push(i);
  int num_alive = static_cast<int>(nodes.size());
  while (num_alive < target && !queue.empty()) {
    const int idx = queue.top();
    queue.pop();
    Node node = nodes[idx];
    if (node.members.size() <= 1 || (node.x1 - node.x0) < 1.0f) continue;  // cannot split further
    const float mx = 0.5f * (node.x0 + node.x1), my = 0.5f * (node.y0 + node.y1);
    Node children[4] = {{node.x0, node.y0, mx, my, {}},
                        {mx, node.y0, node.x1, my, {}},
                        {node.x0, my, mx, node.y1, {}},
                        {mx, my, node.x1, node.y1, {}}};
    for (int m : node.members) {
      const cv::Point2f& p = candidates[m].pt;
      children[(p.x >= mx ? 1 : 0) + (p.y >= my ? 2 : 0)].members.push_back(m);
    }
    alive[idx] = false;
    --num_alive;
    for (Node& c : children) {
      if (c.members.empty()) continue;
      nodes.push_back(std::move(c));
      alive.push_back(true);
      ++num_alive;
      queue.push(static_cast<int>(nodes.size()) - 1);
    }
  }
  // Keep the strongest corner of each node; if there are more nodes than wanted, keep the
  // strongest nodes' winners.
  std::vector<int> winners;
  for (size_t i = 0; i < nodes.size(); ++i) {
    if (!alive[i]) continue;
    int best = nodes[i].members.front();
    for (int m : nodes[i].members) {
      if (candidates[m].response > candidates[best].response) best = m;
    }
    winners.push_back(best);
  }
  if (static_cast<int>(winners.size()) > target) {
    std::stable_sort(winners.begin(), winners.end(),
                     [&](int a, int b) { return candidates[a].response > candidates[b].response; });
    winners.resize(target);
  }
  std::sort(winners.begin(), winners.end());
  for (int w : winners) kept->push_back(candidates[w]);
}

void OrbExtractor::BuildPyramid(const cv::Mat& gray, OrbExtractionCache* cache) const {
  OrbExtractionCache& c = *cache;
  c = OrbExtractionCache();
  c.data_ = gray.data;
  c.size_ = gray.size();
  c.source_ = gray;
  cv::Mat level_img = gray;
  for (int level = 0; level < options_.num_levels; ++level) {
    if (level > 0) {
      const cv::Size size(static_cast<int>(std::lround(gray.cols / scales_[level])),
                          static_cast<int>(std::lround(gray.rows / scales_[level])));
      if (size.width < 2 * kBorder + 8 || size.height < 2 * kBorder + 8) break;
      cv::Mat next;
      cv::resize(level_img, next, size, 0, 0, cv::INTER_LINEAR);
      level_img = next;
    }
    const cv::Rect area(kBorder, kBorder, level_img.cols - 2 * kBorder,
                        level_img.rows - 2 * kBorder);
    if (area.width <= 0 || area.height <= 0) break;
    std::vector<cv::KeyPoint> corners;
    cv::FAST(level_img(area), corners, options_.min_th_fast, true);
    for (cv::KeyPoint& kp : corners) {
      kp.pt.x += area.x;
      kp.pt.y += area.y;
    }
    c.levels_.push_back(level_img);
    c.corners_.push_back(std::move(corners));
    c.blurred_.emplace_back();
  }
}

std::vector<cv::KeyPoint> OrbExtractor::SelectCorners(const OrbExtractionCache& c, int level,
                                                      const cv::Mat& mask, int wanted) const {
  const cv::Mat& level_img = c.levels_[level];
  const cv::Rect area(kBorder, kBorder, level_img.cols - 2 * kBorder, level_img.rows - 2 * kBorder);
  const std::vector<cv::KeyPoint>& corners = c.corners_[level];
  cv::Mat level_mask;
  if (!mask.empty()) cv::resize(mask, level_mask, level_img.size(), 0, 0, cv::INTER_NEAREST);
  const int cells_x = (area.width + kCellSize - 1) / kCellSize;
  const int cells_y = (area.height + kCellSize - 1) / kCellSize;
  std::vector<uint8_t> cell_has_strong(cells_x * cells_y, 0);
  for (const cv::KeyPoint& kp : corners) {
    if (kp.response >= options_.ini_th_fast) {
      const int cx = static_cast<int>(kp.pt.x - area.x) / kCellSize;
      const int cy = static_cast<int>(kp.pt.y - area.y) / kCellSize;
      cell_has_strong[cy * cells_x + cx] = 1;
    }
  }
  std::vector<cv::KeyPoint> candidates;
  candidates.reserve(corners.size());
  for (const cv::KeyPoint& kp : corners) {
    const int cx = static_cast<int>(kp.pt.x - area.x) / kCellSize;
    const int cy = static_cast<int>(kp.pt.y - area.y) / kCellSize;
    if (cell_has_strong[cy * cells_x + cx] && kp.response < options_.ini_th_fast) continue;
    if (!level_mask.empty() &&
        level_mask.at<uint8_t>(static_cast<int>(kp.pt.y), static_cast<int>(kp.pt.x)) != 0)
      continue;
    candidates.push_back(kp);
  }
  std::vector<cv::KeyPoint> kept;
  DistributeQuadtree(candidates, area, wanted, &kept);
  return kept;
}

void OrbExtractor::Orient(const cv::Mat& level_img, std::vector<cv::KeyPoint>* keypoints) const {
  for (cv::KeyPoint& kp : *keypoints) {
    const int cx = cvRound(kp.pt.x);
    const int cy = cvRound(kp.pt.y);
    const uint8_t* center = level_img.ptr<uint8_t>(cy) + cx;
    const int step = static_cast<int>(level_img.step1());
    int m01 = 0, m10 = 0;
    for (int u = -kPatchRadius; u <= kPatchRadius; ++u) m10 += u * center[u];
    for (int v = 1; v <= kPatchRadius; ++v) {
      int v_sum = 0;
      const int d = umax_[v];
      for (int u = -d; u <= d; ++u) {
        const int plus = center[u + v * step], minus = center[u - v * step];
        v_sum += plus - minus;
        m10 += u * (plus + minus);
      }
      m01 += v * v_sum;
    }
    float angle = static_cast<float>(std::atan2(double(m01), double(m10)) * 180.0 / M_PI);
    if (angle < 0) angle += 360.f;
    kp.angle = angle;
  }
}

void OrbExtractor::Describe(OrbExtractionCache* c, int level, std::vector<cv::KeyPoint> keypoints,
                            OrbFeatures* out) const {
  if (c->blurred_[level].empty())
    cv::GaussianBlur(c->levels_[level], c->blurred_[level], cv::Size(7, 7), 2, 2,
                     cv::BORDER_REFLECT_101);
  const cv::Mat& blurred = c->blurred_[level];
  const float scale = static_cast<float>(scales_[level]);
  const PatternPoints& points = PatternAsArrays();
  for (cv::KeyPoint& kp : keypoints) {
    const float a = kp.angle * static_cast<float>(M_PI / 180.0);
    const float ca = std::cos(a), sa = std::sin(a);
    const int cx = cvRound(kp.pt.x);
    const int cy = cvRound(kp.pt.y);
    Descriptor desc{0, 0, 0, 0};
    // Rotated test offsets as row/column offsets into the blurred image: all 512 test points
    // rotated and rounded first (4 at a time), then the comparisons.
    const int step = static_cast<int>(blurred.step1());
    const uint8_t* center = blurred.ptr<uint8_t>(cy) + cx;
    alignas(16) int offsets[2 * 256];
    RotatedOffsets(points, ca, sa, step, offsets);
    for (int bit = 0; bit < 256; ++bit) {
      if (center[offsets[2 * bit]] < center[offsets[2 * bit + 1]])
        desc[bit >> 6] |= (1ULL << (bit & 63));
    }
    kp.octave = level;
    kp.size = 31.0f * scale;
    kp.pt.x *= scale;
    kp.pt.y *= scale;
    out->keypoints.push_back(kp);
    out->descriptors.push_back(desc);
  }
}

OrbFeatures OrbExtractor::Extract(const cv::Mat& gray, const cv::Mat& mask, int num_features,
                                  OrbExtractionCache* cache,
                                  const std::function<bool(const cv::KeyPoint&)>& skip) const {
  CV_Assert(gray.type() == CV_8UC1);
  OrbExtractionCache local;
  OrbExtractionCache& c = cache != nullptr ? *cache : local;
  if (!c.IsFor(gray)) BuildPyramid(gray, &c);
  const int levels = static_cast<int>(c.levels_.size());
  const std::vector<int> features_per_level =
      FeaturesPerLevel(num_features > 0 ? num_features : options_.num_features);
  OrbFeatures out;
  for (int level = 0; level < levels; ++level) {
    std::vector<cv::KeyPoint> kept = SelectCorners(c, level, mask, features_per_level[level]);
    if (skip) {
      // Position and level as Describe reports them.
      const float scale = static_cast<float>(scales_[level]);
      kept.erase(std::remove_if(kept.begin(), kept.end(),
                                [&](const cv::KeyPoint& kp) {
                                  cv::KeyPoint reported = kp;
                                  reported.pt.x *= scale;
                                  reported.pt.y *= scale;
                                  reported.octave = level;
                                  return skip(reported);
                                }),
                 kept.end());
    }
    if (kept.empty()) continue;
    Orient(c.levels_[level], &kept);
    Describe(&c, level, std::move(kept), &out);
  }
  return out;
}

}  // namespace dygslam
