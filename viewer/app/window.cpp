// A window: SDL2 with an EGL/GLES 3 context (X11 or Wayland), the mouse
// orbits, pans and zooms, keys toggle what is drawn and take screenshots.
#include <SDL2/SDL.h>
#include <dlfcn.h>
#include <fmt/format.h>
#include <link.h>

#include <ctime>
#include <filesystem>
#include <stdexcept>

#include "app/run.hpp"
#include "cli/conventions.hpp"
#include "gl/fbo.hpp"
#include "render/renderer.hpp"

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define SCULPT_VIEW_ASAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define SCULPT_VIEW_ASAN 1
#endif

namespace sculpt::view {

namespace {

struct SdlVideo {
  SdlVideo() {
    if (SDL_Init(SDL_INIT_VIDEO) != 0) throw std::runtime_error(fmt::format("SDL: cannot open a display: {}", SDL_GetError()));
  }
  ~SdlVideo() { SDL_Quit(); }
};

struct Window {
  SDL_Window* window = nullptr;
  SDL_GLContext context = nullptr;
  Window() = default;
  Window(const Window&) = delete;
  Window& operator=(const Window&) = delete;
  ~Window() { close(); }
  void close() {
    if (context != nullptr) SDL_GL_DeleteContext(context);
    if (window != nullptr) SDL_DestroyWindow(window);
    context = nullptr;
    window = nullptr;
  }
};

void open(Window& w, const Options& options, int samples) {
  SDL_GL_SetAttribute(SDL_GL_CONTEXT_PROFILE_MASK, SDL_GL_CONTEXT_PROFILE_ES);
  SDL_GL_SetAttribute(SDL_GL_CONTEXT_MAJOR_VERSION, 3);
  SDL_GL_SetAttribute(SDL_GL_CONTEXT_MINOR_VERSION, 0);
  SDL_GL_SetAttribute(SDL_GL_DEPTH_SIZE, 24);
  SDL_GL_SetAttribute(SDL_GL_DOUBLEBUFFER, 1);
  SDL_GL_SetAttribute(SDL_GL_MULTISAMPLEBUFFERS, samples > 1 ? 1 : 0);
  SDL_GL_SetAttribute(SDL_GL_MULTISAMPLESAMPLES, samples > 1 ? samples : 0);
  w.window = SDL_CreateWindow("sculpt-view", SDL_WINDOWPOS_CENTERED, SDL_WINDOWPOS_CENTERED, options.width, options.height,
                              SDL_WINDOW_OPENGL | SDL_WINDOW_RESIZABLE | SDL_WINDOW_SHOWN);
  if (w.window == nullptr) throw std::runtime_error(fmt::format("SDL: cannot open a window: {}", SDL_GetError()));
  w.context = SDL_GL_CreateContext(w.window);
  if (w.context == nullptr) throw std::runtime_error(fmt::format("SDL: no GLES 3 context: {}", SDL_GetError()));
}

std::string screenshot_name(const std::string& dir) {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  localtime_r(&now, &tm);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", &tm);
  for (int i = 0;; ++i) {
    const auto p = std::filesystem::path(dir) / (i == 0 ? fmt::format("sculpt-view-{}.png", stamp)
                                                        : fmt::format("sculpt-view-{}-{}.png", stamp, i));
    if (!std::filesystem::exists(p)) return p.string();
  }
}


// Sanitizer builds only: SDL_Quit terminates EGL, and Mesa then unloads its
// driver, so LeakSanitizer meets Mesa's own leftovers with no module name to
// suppress them by. Pinning the loaded driver keeps the names
// (tests/viewer/lsan.supp suppresses Mesa's leaks, and only those).
void pin_gl_driver() {
#ifdef SCULPT_VIEW_ASAN
  dl_iterate_phdr(
      [](dl_phdr_info* info, std::size_t, void*) {
        const std::string name = info->dlpi_name != nullptr ? info->dlpi_name : "";
        if (name.find("/dri/") != std::string::npos || name.find("libgallium") != std::string::npos ||
            name.find("libEGL_mesa") != std::string::npos || name.find("libLLVM") != std::string::npos) {
          dlopen(name.c_str(), RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE);  // one more reference, never dropped
        }
        return 0;
      },
      nullptr);
#endif
}

}  // namespace

int run_window(const Options& options, Source& source) {
  // EGL under X11 too (SDL defaults to GLX there), and let SDL pick Wayland
  // when WAYLAND_DISPLAY is set.
  SDL_SetHint(SDL_HINT_VIDEO_X11_FORCE_EGL, "1");
  SDL_SetHint(SDL_HINT_OPENGL_ES_DRIVER, "1");
  SdlVideo video;
  Window window;
  try {
    open(window, options, options.samples);
  } catch (const std::runtime_error&) {
    if (options.samples <= 1) throw;
    window.close();  // retried without multisampling
    open(window, options, 0);
  }
  SDL_GL_SetSwapInterval(1);
  pin_gl_driver();
  if (!options.quiet) {
    cli::note(fmt::format("window on {} ({})", SDL_GetCurrentVideoDriver(),
                          reinterpret_cast<const char*>(glGetString(GL_RENDERER))));
  }
  RenderOptions render = options.render;
  Renderer renderer;
  Run run(options, source, true);
  bool dragging_orbit = false, dragging_pan = false, want_screenshot = false, quit = false;
  int width = options.width, height = options.height;
  while (!quit) {
    SDL_Event e;
    while (SDL_PollEvent(&e)) {
      switch (e.type) {
        case SDL_QUIT:
          quit = true;
          break;
        case SDL_MOUSEBUTTONDOWN:
        case SDL_MOUSEBUTTONUP: {
          const bool down = e.type == SDL_MOUSEBUTTONDOWN;
          const bool shift = (SDL_GetModState() & KMOD_SHIFT) != 0;
          if (e.button.button == SDL_BUTTON_LEFT && !shift) dragging_orbit = down;
          if (e.button.button == SDL_BUTTON_RIGHT || e.button.button == SDL_BUTTON_MIDDLE ||
              (e.button.button == SDL_BUTTON_LEFT && shift)) {
            dragging_pan = down;
          }
          break;
        }
        case SDL_MOUSEMOTION:
          if (dragging_orbit) run.camera().orbit(-0.4f * static_cast<float>(e.motion.xrel), 0.4f * static_cast<float>(e.motion.yrel));
          if (dragging_pan) {
            run.camera().pan(static_cast<float>(e.motion.xrel) / static_cast<float>(height),
                             static_cast<float>(e.motion.yrel) / static_cast<float>(height));
          }
          break;
        case SDL_MOUSEWHEEL:
          run.camera().zoom(e.wheel.y > 0 ? 0.9f : 1.0f / 0.9f);
          break;
        case SDL_KEYDOWN:
          switch (e.key.keysym.sym) {
            case SDLK_w: render.wireframe = !render.wireframe; break;
            case SDLK_b: render.boxes = !render.boxes; break;
            case SDLK_c: render.colormap = !render.colormap; break;
            case SDLK_t: render.tools = render.arrows = !render.tools; break;
            case SDLK_o: render.overlay = !render.overlay; break;
            case SDLK_r: run.reset_camera(width, height); break;
            case SDLK_s:
            case SDLK_p:
            case SDLK_F12: want_screenshot = true; break;
            case SDLK_LEFT: run.camera().orbit(5, 0); break;
            case SDLK_RIGHT: run.camera().orbit(-5, 0); break;
            case SDLK_UP: run.camera().orbit(0, 5); break;
            case SDLK_DOWN: run.camera().orbit(0, -5); break;
            case SDLK_PLUS: case SDLK_EQUALS: case SDLK_KP_PLUS: run.camera().zoom(0.9f); break;
            case SDLK_MINUS: case SDLK_KP_MINUS: run.camera().zoom(1.0f / 0.9f); break;
            case SDLK_q: case SDLK_ESCAPE: quit = true; break;
            default: break;
          }
          break;
        default:
          break;
      }
    }
    run.wait_for_frame();
    if (quit || g_stop.load()) break;
    SDL_GL_GetDrawableSize(window.window, &width, &height);
    if (width <= 0 || height <= 0) continue;
    if (!source.has_state()) {
      if (run.finished()) break;
      glBindFramebuffer(GL_FRAMEBUFFER, 0);
      glViewport(0, 0, width, height);
      glClearColor(0.14f, 0.15f, 0.18f, 1.0f);
      glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
      SDL_GL_SwapWindow(window.window);
      continue;
    }
    run.prepare(width, height);
    renderer.sync(source.model(), render);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    renderer.draw(source.model(), run.camera(), width, height, render, run.overlay());
    const auto read = [&] {
      glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
      return Image{width, height, gl::read_pixels_top_down(width, height)};
    };
    if (want_screenshot) {
      want_screenshot = false;
      // A screenshot that cannot be written (no directory, disk full) is
      // reported; the live view the user is working in stays open.
      try {
        const std::string file = screenshot_name(options.screenshot_dir);
        write_png(file, read());
        cli::note("screenshot " + file);
      } catch (const std::exception& e) {
        cli::warning(std::string("screenshot not written: ") + e.what());
      }
    }
    const bool more = run.after_frame(read);
    SDL_GL_SwapWindow(window.window);
    if (!more) break;
  }
  return run.exit_code();
}

}  // namespace sculpt::view
