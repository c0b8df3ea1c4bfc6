// The two ways sculpt-view runs (offscreen, or in a window) and what they
// share: when to write the screenshot and the image sequence, when to stop,
// where the camera starts, what the overlay says.
#pragma once

#include <atomic>
#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include "app/frame_sequence.hpp"
#include "app/options.hpp"
#include "app/source.hpp"
#include "gl/png_io.hpp"
#include "render/camera.hpp"

namespace sculpt::view {

// Set by SIGINT/SIGTERM: finish the frame and leave cleanly.
extern std::atomic<bool> g_stop;
void install_stop_signals();

class Run {
 public:
  // `show_fps`: the overlay says the frame rate (not in offline headless
  // images, which must stay reproducible).
  Run(const Options& options, Source& source, bool show_fps);

  // Pumps the source until the next frame is due at --fps (at once when not
  // `paced`); after a stall the pace restarts instead of bursting to catch up.
  void wait_for_frame(bool paced = true);

  // Before drawing a frame: places the camera on the first state (and on R).
  void prepare(int width, int height);
  void reset_camera(int width, int height);
  Camera& camera() { return camera_; }
  std::vector<std::string> overlay() const;

  // After a frame was drawn; `read` returns its pixels. Adds it to the
  // sequence (frame_sequence.hpp) and writes the screenshot when due. Returns false when the run is over.
  // The pixels are read at most once per frame. Also counts the frame for the
  // overlay's FPS.
  template <class ReadPixels>
  bool after_frame(ReadPixels&& read) {
    count_frame();
    if (source_.has_state()) {
      ++frames_;
      std::optional<Image> image;
      const auto pixels = [&]() -> const Image& { return image ? *image : image.emplace(read()); };
      if (sequence_) sequence_->add(pixels(), std::chrono::steady_clock::now());
      if (!options_.screenshot.empty() && screenshot_due()) {
        write_screenshot(pixels());
        return false;
      }
    }
    return !finished();
  }

  bool finished() const;      // the time or frame limit passed, or a stop signal
  std::string failure() const;  // why the run ended without its screenshot, or ""
  double elapsed_s() const;
  // 0, or 1 after printing failure().
  int exit_code() const;

 private:
  void count_frame();
  bool screenshot_due() const;
  void write_screenshot(const Image& image);

  const Options& options_;
  Source& source_;
  Camera camera_;
  bool placed_ = false;
  long frames_ = 0;
  std::optional<FrameSequence> sequence_;  // with --frames-dir
  bool screenshot_written_ = false;
  const bool show_fps_;
  double fps_ = 0;
  long fps_frames_ = 0;
  std::chrono::steady_clock::time_point start_, fps_since_, next_frame_;
  std::chrono::steady_clock::duration period_;
};

// Both return the process exit code.
int run_headless(const Options& options, Source& source);
int run_window(const Options& options, Source& source);

}  // namespace sculpt::view
