#include "app/frame_sequence.hpp"

#include <fmt/format.h>

#include <fstream>

namespace sculpt::view {
namespace {

// FNV-1a over the pixels: equal images, equal hashes; a collision would only
// merge two frames that differ, never lose the sculpt's last state.
std::uint64_t pixel_hash(const Image& image) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (const std::uint8_t b : image.rgba) h = (h ^ b) * 0x100000001b3ull;
  return h ^ (static_cast<std::uint64_t>(image.width) << 32 | static_cast<std::uint32_t>(image.height));
}

double seconds(FrameSequence::Clock::duration d) { return std::chrono::duration<double>(d).count(); }

}  // namespace

FrameSequence::FrameSequence(std::filesystem::path dir) : dir_(std::move(dir)) {
  std::filesystem::create_directories(dir_);
}

FrameSequence::~FrameSequence() {
  try {
    if (!frames_.empty()) write_timing(Clock::now());
  } catch (...) {  // a destructor must not throw; the frames themselves are written
  }
}

void FrameSequence::add(const Image& image, Clock::time_point at) {
  if (drawn_++ == 0) first_ = at;
  const std::uint64_t h = pixel_hash(image);
  if (!frames_.empty() && h == last_hash_) return;
  last_hash_ = h;
  const std::string file = fmt::format("frame_{:06d}.png", frames_.size() + 1);
  write_png(dir_ / file, image);
  frames_.push_back({file, at});
  write_timing(at);
}

void FrameSequence::write_timing(Clock::time_point end) const {
  const auto path = dir_ / "frames.ffconcat";
  const auto tmp = dir_ / "frames.ffconcat.tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    const double span = seconds(end - first_);
    out << "ffconcat version 1.0\n"
        << fmt::format("# {} frames drawn in {:.2f} s ({:.1f} per second), {} of them distinct\n", drawn_, span,
                       span > 0 ? static_cast<double>(drawn_) / span : 0.0, frames_.size());
    for (std::size_t i = 0; i < frames_.size(); ++i) {
      const auto until = i + 1 < frames_.size() ? frames_[i + 1].shown : end;
      out << "file " << frames_[i].file << "\n" << fmt::format("duration {:.3f}\n", seconds(until - frames_[i].shown));
    }
    // The concat demuxer ignores the last entry's duration unless the file follows once more.
    out << "file " << frames_.back().file << "\n";
    if (!out) throw std::runtime_error(fmt::format("{}: cannot write", tmp.string()));
  }
  std::filesystem::rename(tmp, path);
}

}  // namespace sculpt::view
