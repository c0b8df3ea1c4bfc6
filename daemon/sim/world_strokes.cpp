// World's strokes API (world.hpp): the sink, closing strokes, and block images
// read and exchanged. The capture itself is StrokeRecorder's (stroke_recorder.hpp).
#include <string>

#include "sim/block_image.hpp"
#include "sim/world.hpp"

namespace sculpt::sim {

template <class S>
void World<S>::set_stroke_sink(StrokeSink* sink) {
  close_strokes();  // a stroke the old sink saw open, it sees closed
  stroke_sink_ = sink;
  for (auto& e : recorders_) e->set_sink(sink);
}

template <class S>
void World<S>::close_strokes() {
  for (std::uint32_t bi = 0; bi < bodies_.size(); ++bi) recorders_[bi]->close_now(bodies_[bi], tick_);
}

// Throws std::invalid_argument naming what is wrong (and only then builds a
// message: a swap runs on the real-time thread). `bytes`: the image's size,
// or SIZE_MAX for none.
template <class S>
void World<S>::check_block(const char* what, std::uint32_t body, std::uint32_t block, std::size_t bytes) const {
  auto fail = [&](const std::string& why) { throw std::invalid_argument(std::string(what) + ": " + why); };
  if (body >= bodies_.size())
    fail("body " + std::to_string(body) + " does not exist (" + std::to_string(bodies_.size()) + " bodies)");
  if (bytes == SIZE_MAX) return;
  if (block >= bodies_[body].blocks)
    fail("block " + std::to_string(block) + " of body " + std::to_string(body) + " does not exist (" +
         std::to_string(bodies_[body].blocks) + " blocks)");
  if (bytes != recorders_[body]->layout().bytes)
    fail("an image of body " + std::to_string(body) + " is " + std::to_string(recorders_[body]->layout().bytes) +
         " bytes, not " + std::to_string(bytes));
}

template <class S>
std::size_t World<S>::block_image_bytes(std::uint32_t body) const {
  check_block("block_image_bytes", body, 0, SIZE_MAX);
  return recorders_[body]->layout().bytes;
}

template <class S>
void World<S>::block_image(std::uint32_t body, std::uint32_t block, std::span<std::byte> out) const {
  check_block("block_image", body, block, out.size());
  write_block_image(bodies_[body], recorders_[body]->layout(), block, out.data());
}

template <class S>
void World<S>::exchange_block_image(std::uint32_t body, std::uint32_t block, std::span<std::byte> image) {
  check_block("exchange_block_image", body, block, image.size());
  // The open stroke would hold the swap as part of the stroke, and its images
  // would no longer match what undoing it must put back.
  if (recorders_[body]->open())
    throw std::invalid_argument("exchange_block_image: body " + std::to_string(body) +
                                " has an open stroke; close_strokes() first");
  exchange_block_state(bodies_[body], recorders_[body]->layout(), block, image.data());
  recorders_[body]->swapped(block);
}

template <class S>
std::string World<S>::block_image_error(std::uint32_t body, std::uint32_t block,
                                        std::span<const std::byte> image) const {
  try {
    check_block("block image", body, block, image.size());
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  const Body<S>& b = bodies_[body];
  BlockImageBounds bounds;
  bounds.max_coordinate = kStateMaxCoordinate;
  bounds.max_speed = kStateSpeedMargin * b.speed_limit;
  bounds.dts = 1.0 / settings_.rate_hz / base_substeps_[body];
  bounds.sleep_ticks = settings_.sleep_ticks;
  return sim::block_image_error(b, recorders_[body]->layout(), block, image.data(), bounds);
}

template void World<float>::set_stroke_sink(StrokeSink*);
template void World<double>::set_stroke_sink(StrokeSink*);
template void World<float>::close_strokes();
template void World<double>::close_strokes();
template void World<float>::check_block(const char*, std::uint32_t, std::uint32_t, std::size_t) const;
template void World<double>::check_block(const char*, std::uint32_t, std::uint32_t, std::size_t) const;
template std::size_t World<float>::block_image_bytes(std::uint32_t) const;
template std::size_t World<double>::block_image_bytes(std::uint32_t) const;
template void World<float>::block_image(std::uint32_t, std::uint32_t, std::span<std::byte>) const;
template void World<double>::block_image(std::uint32_t, std::uint32_t, std::span<std::byte>) const;
template std::string World<float>::block_image_error(std::uint32_t, std::uint32_t, std::span<const std::byte>) const;
template std::string World<double>::block_image_error(std::uint32_t, std::uint32_t, std::span<const std::byte>) const;
template void World<float>::exchange_block_image(std::uint32_t, std::uint32_t, std::span<std::byte>);
template void World<double>::exchange_block_image(std::uint32_t, std::uint32_t, std::span<std::byte>);

}  // namespace sculpt::sim
