#include "gl/egl_headless.hpp"

#include <EGL/eglext.h>
#include <fmt/format.h>

#include <cstring>
#include <stdexcept>
#include <vector>

#include "gl/gles.hpp"

namespace sculpt::view::gl {

namespace {

bool has_extension(const char* list, const char* name) {
  if (list == nullptr) return false;
  const std::size_t n = std::strlen(name);
  for (const char* p = list; (p = std::strstr(p, name)) != nullptr; p += n) {
    if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
  }
  return false;
}

std::string egl_error(const char* step) { return fmt::format("EGL: {} failed (0x{:04x})", step, eglGetError()); }

}  // namespace

HeadlessContext::HeadlessContext() {
  const char* client_ext = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  auto get_platform_display =
      reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (get_platform_display == nullptr) throw std::runtime_error("EGL: no eglGetPlatformDisplayEXT (is libegl-mesa0 installed?)");

  EGLint major = 0, minor = 0;
  // Surfaceless first: it needs no device node (works in containers and CI).
  if (has_extension(client_ext, "EGL_MESA_platform_surfaceless")) {
    display_ = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (display_ != EGL_NO_DISPLAY && eglInitialize(display_, &major, &minor)) {
      platform_ = "surfaceless";
    } else {
      display_ = EGL_NO_DISPLAY;
    }
  }
  if (display_ == EGL_NO_DISPLAY && has_extension(client_ext, "EGL_EXT_platform_device")) {
    auto query_devices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    EGLDeviceEXT devices[8];
    EGLint count = 0;
    if (query_devices != nullptr && query_devices(8, devices, &count)) {
      for (EGLint i = 0; i < count && display_ == EGL_NO_DISPLAY; ++i) {
        display_ = get_platform_display(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr);
        if (display_ != EGL_NO_DISPLAY && eglInitialize(display_, &major, &minor)) {
          platform_ = "device";
        } else {
          display_ = EGL_NO_DISPLAY;
        }
      }
    }
  }
  if (display_ == EGL_NO_DISPLAY) {
    throw std::runtime_error(fmt::format(
        "EGL: no headless display (tried EGL_MESA_platform_surfaceless and EGL_EXT_platform_device; "
        "client extensions: {}); install libegl-mesa0 and libgl1-mesa-dri",
        client_ext != nullptr ? client_ext : "none"));
  }

  try {
    if (!has_extension(eglQueryString(display_, EGL_EXTENSIONS), "EGL_KHR_surfaceless_context")) {
      throw std::runtime_error("EGL: the display lacks EGL_KHR_surfaceless_context");
    }
    if (!eglBindAPI(EGL_OPENGL_ES_API)) throw std::runtime_error(egl_error("eglBindAPI(GLES)"));
    const EGLint config_attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_ES3_BIT, EGL_SURFACE_TYPE, EGL_DONT_CARE,
                                     EGL_NONE};
    EGLConfig config = nullptr;
    EGLint configs = 0;
    if (!eglChooseConfig(display_, config_attribs, &config, 1, &configs) || configs == 0) {
      throw std::runtime_error(egl_error("eglChooseConfig (GLES 3)"));
    }
    const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 0, EGL_NONE};
    context_ = eglCreateContext(display_, config, EGL_NO_CONTEXT, context_attribs);
    if (context_ == EGL_NO_CONTEXT) throw std::runtime_error(egl_error("eglCreateContext (GLES 3.0)"));
    if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_)) {
      throw std::runtime_error(egl_error("eglMakeCurrent (surfaceless)"));
    }
  } catch (...) {
    if (context_ != EGL_NO_CONTEXT) eglDestroyContext(display_, context_);
    eglTerminate(display_);
    throw;
  }
}

// The display stays initialised: EGL displays are process-wide (the next
// context reuses it), and eglTerminate makes Mesa unload its driver, which
// leaves LeakSanitizer with a few of Mesa's own blocks it can no longer name
// (no stack, no suppression possible).
HeadlessContext::~HeadlessContext() {
  eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  eglDestroyContext(display_, context_);
  eglReleaseThread();
}

std::string HeadlessContext::renderer() const {
  const auto* r = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  return r != nullptr ? r : "unknown";
}

}  // namespace sculpt::view::gl
