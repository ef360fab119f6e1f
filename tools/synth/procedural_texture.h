// Procedural surface textures for the synthetic scenes: value noise at several scales under
// random rectangles, rotated rectangles, ellipses and triangles of random colour and size. The
// pattern is a function of surface coordinates (texels at a fixed density in metres), so a surface
// looks the same from every view, and it is non-repetitive (every shape is drawn at random), which
// gives ORB/FAST many distinctive corners at several scales.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>

namespace dygslam {

enum class TextureStyle {
  kRoom,       // muted background, mixed-contrast shapes (walls, floor, ceiling)
  kFurniture,  // warmer background, denser shapes
  kClothing,   // saturated colours (moving objects standing in for people)
};

// A CV_8UC3 (BGR) texture of `width_m` x `height_m` metres at `texels_per_metre`; texel (x, y)
// covers surface coordinates [x, x+1) / texels_per_metre. Deterministic in `seed`.
cv::Mat MakeProceduralTexture(double width_m, double height_m, double texels_per_metre,
                              uint64_t seed, TextureStyle style);

}  // namespace dygslam
