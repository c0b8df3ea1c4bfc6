// A GLES 3 context with no window and no display server: EGL's surfaceless
// platform (Mesa), or failing that the device platform. What is drawn goes
// into an Fbo (gl/fbo.hpp).
#pragma once

#include <EGL/egl.h>

#include <string>

namespace sculpt::view::gl {

class HeadlessContext {
 public:
  // Creates the context and makes it current on this thread. Throws
  // std::runtime_error saying which EGL step failed and what was tried.
  HeadlessContext();
  ~HeadlessContext();
  HeadlessContext(const HeadlessContext&) = delete;
  HeadlessContext& operator=(const HeadlessContext&) = delete;

  // "surfaceless" or "device", and GL_RENDERER (e.g. "llvmpipe (LLVM 15.0.6, 256 bits)").
  const std::string& platform() const { return platform_; }
  std::string renderer() const;

 private:
  EGLDisplay display_ = EGL_NO_DISPLAY;
  EGLContext context_ = EGL_NO_CONTEXT;
  std::string platform_;
};

}  // namespace sculpt::view::gl
