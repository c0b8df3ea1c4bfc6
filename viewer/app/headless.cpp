// Offscreen: an EGL surfaceless context and an FBO; frames at --fps.
#include <fmt/format.h>

#include <chrono>
#include <filesystem>
#include <thread>

#include "app/run.hpp"
#include "gl/egl_headless.hpp"
#include "gl/fbo.hpp"
#include "render/renderer.hpp"

namespace sculpt::view {

int run_headless(const Options& options, Source& source) {
  gl::HeadlessContext context;
  if (!options.quiet) fmt::print(stderr, "sculpt-view: headless ({}, {})\n", context.platform(), context.renderer());
  gl::Fbo fbo(options.width, options.height, options.samples);
  Renderer renderer;
  Run run(options, source);
  if (!options.frames_dir.empty()) std::filesystem::create_directories(options.frames_dir);

  using Clock = std::chrono::steady_clock;
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / options.fps));
  auto next = Clock::now();
  auto fps_since = Clock::now();
  long fps_frames = 0;
  // Offline scenes never change: no reason to pace their frames.
  const bool paced = options.scene.empty() || !options.frames_dir.empty() || options.after_seconds.has_value();
  while (true) {
    const double wait = paced ? std::chrono::duration<double>(next - Clock::now()).count() : 0.0;
    source.pump(wait > 0 ? wait : 0.0);
    next = std::max(next + period, Clock::now() - period);   // no catch-up burst after a stall
    if (g_stop.load()) break;
    if (!source.has_state()) {
      if (run.finished()) break;
      continue;
    }
    run.prepare(options.width, options.height);
    renderer.sync(source.model(), options.render);
    fbo.bind();
    renderer.draw(source.model(), run.camera(), options.width, options.height, options.render, run.overlay());
    const bool more = run.after_frame([&] { return Image{options.width, options.height, fbo.read_rgba()}; });
    ++fps_frames;
    const double span = std::chrono::duration<double>(Clock::now() - fps_since).count();
    if (span >= 1.0) {
      if (options.scene.empty()) run.note_fps(static_cast<double>(fps_frames) / span);  // offline images stay reproducible
      fps_frames = 0;
      fps_since = Clock::now();
    }
    if (!more) break;
  }
  const std::string failure = run.failure();
  if (!failure.empty()) {
    fmt::print(stderr, "sculpt-view: {}\n", failure);
    return 1;
  }
  return 0;
}

}  // namespace sculpt::view
