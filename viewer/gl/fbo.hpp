// An offscreen render target: multisampled colour + depth, resolved into a
// single-sampled colour buffer that read_rgba() copies out (top row first).
#pragma once

#include <cstdint>
#include <vector>

#include "gl/gles.hpp"

namespace sculpt::view::gl {

class Fbo {
 public:
  // samples 0 or 1: no multisampling. Throws GlError when incomplete.
  Fbo(int width, int height, int samples);

  void bind() const;      // the target of the next draws
  // Resolves (when multisampled) and reads: width*height*4 bytes, top row first.
  std::vector<std::uint8_t> read_rgba();

  int width() const { return width_; }
  int height() const { return height_; }

 private:
  int width_;
  int height_;
  int samples_;
  Framebuffer draw_;
  Renderbuffer draw_color_;
  Renderbuffer depth_;
  Framebuffer resolve_;   // only when multisampled
  Renderbuffer resolve_color_;
};

// Reads the currently bound read framebuffer (a window's back buffer, say):
// width*height*4 bytes, top row first.
std::vector<std::uint8_t> read_pixels_top_down(int width, int height);

}  // namespace sculpt::view::gl
