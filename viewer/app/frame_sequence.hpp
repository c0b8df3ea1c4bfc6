// The image sequence of --frames-dir: every frame that shows something new
// becomes DIR/frame_NNNNNN.png, and DIR/frames.ffconcat says how long each
// was on screen. A renderer slower than --fps (llvmpipe on a busy machine)
// or a sculpt at rest draws the same picture again; such repeats lengthen the
// previous frame instead of being written again, so the files are what was
// drawn and the timing file gives the real rate. The timing file is ffmpeg's
// concat format (`ffmpeg -f concat -i DIR/frames.ffconcat`): a video made
// from it plays at the speed the viewer drew.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "gl/png_io.hpp"

namespace sculpt::view {

class FrameSequence {
 public:
  using Clock = std::chrono::steady_clock;

  explicit FrameSequence(std::filesystem::path dir);
  // Writes the timing file once more with the last frame's full duration.
  ~FrameSequence();
  FrameSequence(const FrameSequence&) = delete;
  FrameSequence& operator=(const FrameSequence&) = delete;

  // A frame drawn at `at`: written when its pixels differ from the last one's.
  void add(const Image& image, Clock::time_point at);

  long drawn() const { return drawn_; }
  long written() const { return static_cast<long>(frames_.size()); }

 private:
  struct Frame {
    std::string file;
    Clock::time_point shown;
  };
  void write_timing(Clock::time_point end) const;

  std::filesystem::path dir_;
  std::vector<Frame> frames_;
  std::uint64_t last_hash_ = 0;
  long drawn_ = 0;
  Clock::time_point first_{};
};

}  // namespace sculpt::view
