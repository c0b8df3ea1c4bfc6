#include "app/run.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <csignal>
#include <filesystem>

#include "cli/conventions.hpp"

namespace sculpt::view {

std::atomic<bool> g_stop{false};

void install_stop_signals() {
  struct sigaction sa {};
  sa.sa_handler = [](int) { g_stop.store(true); };
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

using Clock = std::chrono::steady_clock;

Run::Run(const Options& options, Source& source, bool show_fps)
    : options_(options),
      source_(source),
      show_fps_(show_fps),
      start_(Clock::now()),
      fps_since_(start_),
      next_frame_(start_),
      period_(std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / options.fps))) {
  if (!options_.frames_dir.empty()) sequence_.emplace(options_.frames_dir);
}

void Run::wait_for_frame(bool paced) {
  const double wait = paced ? std::chrono::duration<double>(next_frame_ - Clock::now()).count() : 0.0;
  source_.pump(wait > 0 ? wait : 0.0);
  next_frame_ = std::max(next_frame_ + period_, Clock::now() - period_);
}

void Run::count_frame() {
  ++fps_frames_;
  const double span = std::chrono::duration<double>(Clock::now() - fps_since_).count();
  if (span >= 1.0) {
    if (show_fps_) fps_ = static_cast<double>(fps_frames_) / span;
    fps_frames_ = 0;
    fps_since_ = Clock::now();
  }
}

int Run::exit_code() const {
  const std::string why = failure();
  if (why.empty()) return 0;
  cli::error(why);
  return 1;
}

void Run::reset_camera(int width, int height) {
  const ViewModel& m = source_.model();
  camera_ = Camera{};
  const Aabb box = m.scene_bounds.empty() ? m.bounds_now() : m.scene_bounds;
  camera_.fit(box, static_cast<float>(width) / static_cast<float>(height));
  const CameraSpec& c = options_.camera;
  if (c.yaw_deg) camera_.yaw_deg = *c.yaw_deg;
  if (c.pitch_deg) camera_.pitch_deg = *c.pitch_deg;
  if (c.distance) camera_.distance = *c.distance;
  if (c.target) camera_.target = Eigen::Vector3f((*c.target)[0], (*c.target)[1], (*c.target)[2]);
}

void Run::prepare(int width, int height) {
  if (!placed_ && source_.has_state()) {
    reset_camera(width, height);
    placed_ = true;
  }
}

std::vector<std::string> Run::overlay() const {
  std::vector<std::string> lines = source_.describe();
  if (fps_ > 0) lines.push_back(fmt::format("VIEW {:.1f} FPS", fps_));
  return lines;
}

double Run::elapsed_s() const {
  return std::chrono::duration<double>(Clock::now() - start_).count();
}

bool Run::screenshot_due() const {
  if (options_.after_frames) return frames_ >= *options_.after_frames;
  if (options_.after_seconds) return elapsed_s() >= *options_.after_seconds;
  return frames_ >= 1;
}

bool Run::finished() const {
  if (g_stop.load()) return true;
  if (options_.screenshot.empty()) {
    if (options_.after_frames && frames_ >= *options_.after_frames) return true;
  }
  if (options_.after_seconds && elapsed_s() >= *options_.after_seconds) {
    // With a screenshot to take, the time limit ends the run only when the
    // screenshot is waiting for frames that will not come (no state yet).
    return options_.screenshot.empty() || !source_.has_state() || options_.after_frames.has_value();
  }
  return false;
}

std::string Run::failure() const {
  if (!options_.screenshot.empty() && !screenshot_written_) {
    if (g_stop.load()) return "stopped by a signal before the screenshot";
    if (!source_.has_state()) return fmt::format("nothing to show after {:.1f} s: no keyframe from the daemon", elapsed_s());
    return fmt::format("the time limit passed after {} of {} frames", frames_, options_.after_frames.value_or(1));
  }
  return "";
}

void Run::write_screenshot(const Image& image) {
  write_png(options_.screenshot, image);
  screenshot_written_ = true;
  if (!options_.quiet) cli::note(fmt::format("wrote {} ({}x{})", options_.screenshot, image.width, image.height));
}

}  // namespace sculpt::view
