// The two ways sculpt-view runs (offscreen, or in a window) and what they
// share: when to write the snapshot and the image sequence, when to stop,
// where the camera starts, what the overlay says.
#pragma once

#include <atomic>
#include <chrono>
#include <string>
#include <vector>

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
  Run(const Options& options, Source& source);

  // Before drawing a frame: places the camera on the first state (and on R).
  void prepare(int width, int height);
  void reset_camera(int width, int height);
  Camera& camera() { return camera_; }
  std::vector<std::string> overlay() const;

  // After a frame was drawn; `read` returns its pixels. Writes the sequence
  // frame and the snapshot when due. Returns false when the run is over.
  template <class ReadPixels>
  bool after_frame(ReadPixels&& read) {
    if (source_.has_state()) {
      ++frames_;
      if (!options_.frames_dir.empty()) write_sequence(read());
      if (!options_.snapshot.empty() && snapshot_due()) {
        write_snapshot(read());
        return false;
      }
    }
    return !finished();
  }

  bool finished() const;      // the time or frame limit passed, or a stop signal
  std::string failure() const;  // why the run ended without its snapshot, or ""
  double elapsed_s() const;
  long frames() const { return frames_; }
  void note_fps(double fps) { fps_ = fps; }

 private:
  bool snapshot_due() const;
  void write_sequence(const Image& image);
  void write_snapshot(const Image& image);

  const Options& options_;
  Source& source_;
  Camera camera_;
  bool placed_ = false;
  long frames_ = 0;
  long sequence_ = 0;
  bool snapshot_written_ = false;
  double fps_ = 0;
  std::chrono::steady_clock::time_point start_;
};

// Both return the process exit code.
int run_headless(const Options& options, Source& source);
int run_window(const Options& options, Source& source);

}  // namespace sculpt::view
