// sculpt-view: watch sculptd's meshes, offscreen (PNGs) or in a window.
#include <fmt/format.h>

#include <cstdlib>
#include <exception>

#include "cli/conventions.hpp"
#include "app/options.hpp"
#include "app/run.hpp"
#include "app/source.hpp"

int main(int argc, char** argv) {
  using namespace sculpt::view;
  sculpt::cli::set_program("sculpt-view");
  int exit_code = 0;
  const auto options = parse_options(argc, argv, exit_code);
  if (!options) return exit_code;
  install_stop_signals();
  try {
    const bool display = std::getenv("DISPLAY") != nullptr || std::getenv("WAYLAND_DISPLAY") != nullptr;
    if (options->window && !display) {
      sculpt::cli::error("--window: no display (neither DISPLAY nor WAYLAND_DISPLAY is set)");
      return 2;
    }
    // Images on request are made offscreen unless a window is asked for.
    const bool headless = options->headless || !display ||
                          (!options->window && (!options->screenshot.empty() || !options->frames_dir.empty()));
#ifndef SCULPT_VIEW_HAVE_SDL
    if (!headless) {
      sculpt::cli::error("built without SDL2: no window mode (use --headless)");
      return 2;
    }
#endif
    if (headless && options->screenshot.empty() && options->frames_dir.empty()) {
      sculpt::cli::error(fmt::format("{}: nothing to write; give --screenshot FILE.png or --frames-dir DIR, "
                                     "or run it under a display for a window",
                                     display ? "--headless" : "no display (neither DISPLAY nor WAYLAND_DISPLAY is set)"));
      return 2;
    }
    check_outputs(*options);
    auto source = options->scene.empty() ? make_live_source(*options) : make_offline_source(options->scene);
    if (headless) return run_headless(*options, *source);
#ifdef SCULPT_VIEW_HAVE_SDL
    return run_window(*options, *source);
#endif
  } catch (const std::exception& e) {
    sculpt::cli::error(e.what());
    return 1;
  }
  return 0;
}
