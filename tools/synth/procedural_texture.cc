#include "tools/synth/procedural_texture.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "core/base/error.h"
#include "tools/synth/random.h"

namespace dygslam {
namespace {

struct StyleParams {
  double base_grey_lo, base_grey_hi;  // background mean intensity
  double base_saturation;             // background chroma amplitude
  double noise_amplitude;             // value-noise amplitude (intensity units)
  double shape_saturation;            // chroma amplitude of shapes
  double density_scale;               // multiplies the shape densities
};

StyleParams ParamsFor(TextureStyle style) {
  switch (style) {
    case TextureStyle::kRoom:
      return {90, 170, 35, 45, 70, 1.0};
    case TextureStyle::kFurniture:
      return {70, 150, 50, 40, 80, 1.3};
    case TextureStyle::kClothing:
      return {60, 160, 90, 40, 120, 1.5};
  }
  return {90, 170, 35, 45, 70, 1.0};
}

cv::Scalar RandomColour(SynthRng& rng, double grey_lo, double grey_hi, double saturation) {
  const double grey = rng.Uniform(grey_lo, grey_hi);
  double c[3];
  for (double& v : c) v = std::clamp(grey + saturation * rng.Uniform(-1.0, 1.0), 0.0, 255.0);
  return cv::Scalar(c[0], c[1], c[2]);
}

// Smooth value noise: a random lattice with `cell_texels` spacing, bicubically interpolated.
void AddValueNoise(cv::Mat& image, double cell_texels, double amplitude, bool coloured,
                   SynthRng& rng) {
  const int gw = std::max(2, static_cast<int>(std::ceil(image.cols / cell_texels)) + 1);
  const int gh = std::max(2, static_cast<int>(std::ceil(image.rows / cell_texels)) + 1);
  cv::Mat lattice(gh, gw, CV_32FC3);
  for (int y = 0; y < gh; ++y) {
    for (int x = 0; x < gw; ++x) {
      const float g = static_cast<float>(rng.Uniform(-amplitude, amplitude));
      cv::Vec3f v(g, g, g);
      if (coloured) {
        for (int k = 0; k < 3; ++k) v[k] += static_cast<float>(rng.Uniform(-0.4, 0.4) * amplitude);
      }
      lattice.at<cv::Vec3f>(y, x) = v;
    }
  }
  cv::Mat up;
  cv::resize(lattice, up, image.size(), 0, 0, cv::INTER_CUBIC);
  image += up;
}

}  // namespace

cv::Mat MakeProceduralTexture(double width_m, double height_m, double texels_per_metre,
                              uint64_t seed, TextureStyle style) {
  DYGSLAM_CHECK_OPTION(width_m > 0 && height_m > 0, "texture size");
  DYGSLAM_CHECK_OPTION(texels_per_metre >= 20 && texels_per_metre <= 4000, "texels_per_metre");
  const int cols = std::max(2, static_cast<int>(std::ceil(width_m * texels_per_metre)) + 1);
  const int rows = std::max(2, static_cast<int>(std::ceil(height_m * texels_per_metre)) + 1);
  const StyleParams params = ParamsFor(style);
  SynthRng rng(MixSeed(seed, 0x7E47u));

  // Background: a base colour under value noise at three scales (0.9 m, 0.3 m, 0.09 m).
  const cv::Scalar base =
      RandomColour(rng, params.base_grey_lo, params.base_grey_hi, params.base_saturation);
  cv::Mat background(rows, cols, CV_32FC3, cv::Scalar(base[0], base[1], base[2]));
  AddValueNoise(background, 0.9 * texels_per_metre, params.noise_amplitude, true, rng);
  AddValueNoise(background, 0.3 * texels_per_metre, 0.6 * params.noise_amplitude, true, rng);
  AddValueNoise(background, 0.09 * texels_per_metre, 0.35 * params.noise_amplitude, false, rng);
  cv::Mat texture;
  background.convertTo(texture, CV_8UC3);

  // Shapes at three scales, large first so that smaller ones lie on top of them.
  struct Scale {
    double min_m, max_m, per_square_metre;
  };
  const Scale scales[] = {{0.15, 0.55, 3.0}, {0.04, 0.15, 22.0}, {0.012, 0.04, 110.0}};
  const double area = width_m * height_m;
  constexpr int kShift = 4;  // sub-texel precision of the vertices
  constexpr double kOne = 1 << kShift;
  for (const Scale& scale : scales) {
    const double expected = scale.per_square_metre * params.density_scale * area;
    const int count =
        static_cast<int>(expected) + (rng.Uniform() < expected - std::floor(expected));
    for (int i = 0; i < count; ++i) {
      const double cx = rng.Uniform(-0.1, 1.1) * cols;
      const double cy = rng.Uniform(-0.1, 1.1) * rows;
      const double w = rng.Uniform(scale.min_m, scale.max_m) * texels_per_metre;
      const double h = w * rng.Uniform(0.35, 1.0 / 0.35);
      const double kind = rng.Uniform();
      const double angle = rng.Uniform(0.0, 3.141592653589793);
      const cv::Scalar colour = RandomColour(rng, 10, 245, params.shape_saturation);
      if (kind < 0.45) {  // axis-aligned rectangle
        cv::Point p[4] = {
            {static_cast<int>((cx - w / 2) * kOne), static_cast<int>((cy - h / 2) * kOne)},
            {static_cast<int>((cx + w / 2) * kOne), static_cast<int>((cy - h / 2) * kOne)},
            {static_cast<int>((cx + w / 2) * kOne), static_cast<int>((cy + h / 2) * kOne)},
            {static_cast<int>((cx - w / 2) * kOne), static_cast<int>((cy + h / 2) * kOne)}};
        cv::fillConvexPoly(texture, p, 4, colour, cv::LINE_AA, kShift);
      } else if (kind < 0.7) {  // rotated rectangle
        const double c = std::cos(angle), s = std::sin(angle);
        cv::Point p[4];
        const double dx[4] = {-w / 2, w / 2, w / 2, -w / 2};
        const double dy[4] = {-h / 2, -h / 2, h / 2, h / 2};
        for (int k = 0; k < 4; ++k) {
          p[k] = cv::Point(static_cast<int>((cx + c * dx[k] - s * dy[k]) * kOne),
                           static_cast<int>((cy + s * dx[k] + c * dy[k]) * kOne));
        }
        cv::fillConvexPoly(texture, p, 4, colour, cv::LINE_AA, kShift);
      } else if (kind < 0.87) {  // ellipse (blob)
        cv::ellipse(texture, cv::Point(static_cast<int>(cx * kOne), static_cast<int>(cy * kOne)),
                    cv::Size(static_cast<int>(w / 2 * kOne), static_cast<int>(h / 2 * kOne)),
                    angle * 180.0 / 3.141592653589793, 0, 360, colour, cv::FILLED, cv::LINE_AA,
                    kShift);
      } else {  // triangle
        cv::Point p[3];
        for (int k = 0; k < 3; ++k) {
          const double a = angle + k * 2.0943951023931953 + rng.Uniform(-0.5, 0.5);
          p[k] = cv::Point(static_cast<int>((cx + std::cos(a) * w / 2) * kOne),
                           static_cast<int>((cy + std::sin(a) * h / 2) * kOne));
        }
        cv::fillConvexPoly(texture, p, 3, colour, cv::LINE_AA, kShift);
      }
    }
  }
  return texture;
}

}  // namespace dygslam
