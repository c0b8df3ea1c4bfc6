#include "gl/fbo.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstring>

namespace sculpt::view::gl {

namespace {

Renderbuffer make_renderbuffer(GLenum format, int width, int height, int samples) {
  GLuint name = 0;
  glGenRenderbuffers(1, &name);
  Renderbuffer rb(name);
  glBindRenderbuffer(GL_RENDERBUFFER, name);
  if (samples > 1) {
    glRenderbufferStorageMultisample(GL_RENDERBUFFER, samples, format, width, height);
  } else {
    glRenderbufferStorage(GL_RENDERBUFFER, format, width, height);
  }
  return rb;
}

Framebuffer make_framebuffer() {
  GLuint name = 0;
  glGenFramebuffers(1, &name);
  return Framebuffer(name);
}

void require_complete(const char* what) {
  const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
  if (status != GL_FRAMEBUFFER_COMPLETE) {
    throw GlError(fmt::format("{} framebuffer incomplete (0x{:04x})", what, status));
  }
}

}  // namespace

Fbo::Fbo(int width, int height, int samples) : width_(width), height_(height), samples_(samples > 1 ? samples : 0) {
  GLint max_samples = 0;
  glGetIntegerv(GL_MAX_SAMPLES, &max_samples);
  samples_ = std::min(samples_, static_cast<int>(max_samples));
  if (samples_ <= 1) samples_ = 0;

  draw_ = make_framebuffer();
  glBindFramebuffer(GL_FRAMEBUFFER, draw_.get());
  draw_color_ = make_renderbuffer(GL_RGBA8, width, height, samples_);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, draw_color_.get());
  depth_ = make_renderbuffer(GL_DEPTH_COMPONENT24, width, height, samples_);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_.get());
  require_complete("draw");
  if (samples_ > 0) {
    resolve_ = make_framebuffer();
    glBindFramebuffer(GL_FRAMEBUFFER, resolve_.get());
    resolve_color_ = make_renderbuffer(GL_RGBA8, width, height, 0);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, resolve_color_.get());
    require_complete("resolve");
  }
  check("Fbo setup");
}

void Fbo::bind() const {
  glBindFramebuffer(GL_FRAMEBUFFER, draw_.get());
  glViewport(0, 0, width_, height_);
}

std::vector<std::uint8_t> Fbo::read_rgba() {
  if (samples_ > 0) {
    glBindFramebuffer(GL_READ_FRAMEBUFFER, draw_.get());
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, resolve_.get());
    glBlitFramebuffer(0, 0, width_, height_, 0, 0, width_, height_, GL_COLOR_BUFFER_BIT, GL_NEAREST);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, resolve_.get());
  } else {
    glBindFramebuffer(GL_READ_FRAMEBUFFER, draw_.get());
  }
  auto pixels = read_pixels_top_down(width_, height_);
  glBindFramebuffer(GL_FRAMEBUFFER, draw_.get());
  check("Fbo::read_rgba");
  return pixels;
}

std::vector<std::uint8_t> read_pixels_top_down(int width, int height) {
  const std::size_t row = static_cast<std::size_t>(width) * 4;
  std::vector<std::uint8_t> pixels(row * static_cast<std::size_t>(height));
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, pixels.data());
  // GL's first row is the bottom one; images start at the top.
  std::vector<std::uint8_t> tmp(row);
  for (int y = 0; y < height / 2; ++y) {
    std::uint8_t* a = pixels.data() + static_cast<std::size_t>(y) * row;
    std::uint8_t* b = pixels.data() + static_cast<std::size_t>(height - 1 - y) * row;
    std::memcpy(tmp.data(), a, row);
    std::memcpy(a, b, row);
    std::memcpy(b, tmp.data(), row);
  }
  return pixels;
}

}  // namespace sculpt::view::gl
