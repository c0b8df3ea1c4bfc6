// Offscreen: an EGL surfaceless context and an FBO; frames at --fps.
#include <fmt/format.h>

#include "app/run.hpp"
#include "cli/conventions.hpp"
#include "gl/egl_headless.hpp"
#include "gl/fbo.hpp"
#include "render/renderer.hpp"

namespace sculpt::view {

int run_headless(const Options& options, Source& source) {
  gl::HeadlessContext context;
  if (!options.quiet) cli::note(fmt::format("headless ({}, {})", context.platform(), context.renderer()));
  gl::Fbo fbo(options.width, options.height, options.samples);
  Renderer renderer;
  Run run(options, source, options.scene.empty());  // offline images stay reproducible: no FPS
  // Offline scenes never change: no reason to pace their frames.
  const bool paced = options.scene.empty() || !options.frames_dir.empty() || options.after_seconds.has_value();
  while (true) {
    run.wait_for_frame(paced);
    if (g_stop.load()) break;
    if (!source.has_state()) {
      if (run.finished()) break;
      continue;
    }
    run.prepare(options.width, options.height);
    renderer.sync(source.model(), options.render);
    fbo.bind();
    renderer.draw(source.model(), run.camera(), options.width, options.height, options.render, run.overlay());
    if (!run.after_frame([&] { return Image{options.width, options.height, fbo.read_rgba()}; })) break;
  }
  return run.exit_code();
}

}  // namespace sculpt::view
