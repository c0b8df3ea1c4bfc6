// Comparing rendered images with a tolerance (llvmpipe versions and CPU
// features change edges and rounding; never compare bytes).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>

#include "gl/png_io.hpp"

namespace sculpt::viewtest {

struct ImageDiff {
  bool same_size = false;
  double mean_abs = 0;      // mean |difference| over all RGB channels, 0..255
  double bad_fraction = 0;  // pixels whose largest channel difference exceeds `pixel_threshold`
};

inline ImageDiff compare(const view::Image& a, const view::Image& b, int pixel_threshold = 32) {
  ImageDiff d;
  if (a.width != b.width || a.height != b.height) return d;
  d.same_size = true;
  const std::size_t n = static_cast<std::size_t>(a.width) * static_cast<std::size_t>(a.height);
  double sum = 0;
  std::size_t bad = 0;
  for (std::size_t i = 0; i < n; ++i) {
    int worst = 0;
    for (int c = 0; c < 3; ++c) {
      const int diff = std::abs(int{a.rgba[i * 4 + c]} - int{b.rgba[i * 4 + c]});
      sum += diff;
      worst = std::max(worst, diff);
    }
    if (worst > pixel_threshold) ++bad;
  }
  d.mean_abs = sum / static_cast<double>(n * 3);
  d.bad_fraction = static_cast<double>(bad) / static_cast<double>(n);
  return d;
}

// Within tolerance: at most 1 % of the pixels differ visibly, and on average
// by less than 2 levels.
inline bool close_enough(const ImageDiff& d) { return d.same_size && d.bad_fraction <= 0.01 && d.mean_abs <= 2.0; }

inline std::string describe(const ImageDiff& d) {
  if (!d.same_size) return "sizes differ";
  return "mean |diff| " + std::to_string(d.mean_abs) + ", " + std::to_string(d.bad_fraction * 100) + " % of pixels differ";
}

// Pixels whose colour is far from the background (the viewer clears to
// (36, 38, 46)): how much of the image shows something.
inline double content_fraction(const view::Image& img) {
  std::size_t lit = 0;
  const std::size_t n = static_cast<std::size_t>(img.width) * static_cast<std::size_t>(img.height);
  for (std::size_t i = 0; i < n; ++i) {
    const int r = img.rgba[i * 4], g = img.rgba[i * 4 + 1], b = img.rgba[i * 4 + 2];
    if (std::abs(r - 36) + std::abs(g - 38) + std::abs(b - 46) > 60) ++lit;
  }
  return static_cast<double>(lit) / static_cast<double>(n);
}

// Pixels of a mesh material's hue: clearly red (rubber), green (jelly) or tan (clay).
inline double mesh_colour_fraction(const view::Image& img) {
  std::size_t hits = 0;
  const std::size_t n = static_cast<std::size_t>(img.width) * static_cast<std::size_t>(img.height);
  for (std::size_t i = 0; i < n; ++i) {
    const int r = img.rgba[i * 4], g = img.rgba[i * 4 + 1], b = img.rgba[i * 4 + 2];
    const bool red = r > 90 && r > g + 40 && r > b + 40;
    const bool green = g > 90 && g > r + 30 && g > b + 20;
    if (red || green) ++hits;
  }
  return static_cast<double>(hits) / static_cast<double>(n);
}

}  // namespace sculpt::viewtest
