// Helpers of the strokes tests: a sink that keeps every stroke and its images,
// and World::state() taken apart by block, independently of the block
// images, so the tests can tell what a stroke changed.
#pragma once

#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include "sim/strokes.hpp"
#include "sim/kernels.hpp"
#include "sim/world.hpp"

namespace sculpt::sim::test {

struct RecordedStroke {
  std::uint32_t body = 0;
  StrokeSummary summary;
  bool closed = false;
  std::vector<std::uint32_t> blocks{};           // in capture order
  std::vector<std::vector<std::byte>> images{};  // beside them
};

// Keeps every stroke; flags what breaks the sink's contract.
class KeepingSink : public StrokeSink {
 public:
  explicit KeepingSink(std::size_t bodies) : open_(bodies, -1) {}
  void opened(std::uint32_t body, std::uint64_t tick) override {
    EXPECT_EQ(open_.at(body), -1) << "body " << body << " opened twice";
    open_[body] = static_cast<int>(strokes.size());
    strokes.push_back({.body = body, .summary = {.first_tick = tick}});
  }
  void captured(std::uint32_t body, std::uint32_t block, std::span<const std::byte> image) override {
    ASSERT_NE(open_.at(body), -1) << "captured with no stroke open";
    RecordedStroke& e = strokes[static_cast<std::size_t>(open_[body])];
    for (std::uint32_t b : e.blocks) EXPECT_NE(b, block) << "block " << block << " captured twice";
    e.blocks.push_back(block);
    e.images.emplace_back(image.begin(), image.end());
  }
  void closed(std::uint32_t body, const StrokeSummary& s) override {
    ASSERT_NE(open_.at(body), -1) << "closed with no stroke open";
    RecordedStroke& e = strokes[static_cast<std::size_t>(open_[body])];
    EXPECT_EQ(s.first_tick, e.summary.first_tick);
    e.summary = s;
    e.closed = true;
    open_[body] = -1;
  }
  bool any_open() const {
    for (int o : open_)
      if (o != -1) return true;
    return false;
  }
  std::vector<RecordedStroke> strokes;

 private:
  std::vector<int> open_;
};

// One body's part of World::state(): per block, every byte stored for it or
// its vertices (the packed records in current-first order); the ring stamps
// left out (a clock: block_image.hpp says why); `derived` what the body keeps
// of its blocks (the awake count and the box).
struct BodyBytes {
  std::vector<std::vector<std::byte>> blocks;
  std::vector<std::byte> derived;
};

class StateParser {
 public:
  explicit StateParser(std::span<const std::byte> in) : in_(in) {}
  template <class T>
  T value() {
    T v{};
    EXPECT_LE(at_ + sizeof v, in_.size()) << "the state's format changed?";
    if (at_ + sizeof v <= in_.size()) std::memcpy(&v, in_.data() + at_, sizeof v);
    at_ += sizeof v;
    return v;
  }
  template <class T>
  void value_into(std::vector<std::byte>& out) {
    const T v = value<T>();
    const auto* p = reinterpret_cast<const std::byte*>(&v);
    out.insert(out.end(), p, p + sizeof v);
  }
  // An array's bytes; its count must be one of `counts` (none: any count).
  std::span<const std::byte> array(std::size_t elem, std::initializer_list<std::size_t> counts) {
    const auto n = value<std::uint64_t>();
    bool ok = counts.size() == 0;
    for (std::size_t c : counts) ok = ok || c == n;
    EXPECT_TRUE(ok) << "an array of " << n << " entries at byte " << at_ << ": the state's format changed?";
    if (!ok || at_ + n * elem > in_.size()) return {};
    const std::span<const std::byte> s = in_.subspan(at_, n * elem);
    at_ += n * elem;
    return s;
  }

 private:
  std::span<const std::byte> in_;
  std::size_t at_ = 0;
};

inline void append(std::vector<std::byte>& to, std::span<const std::byte> a, std::size_t from, std::size_t count) {
  to.insert(to.end(), a.begin() + static_cast<std::ptrdiff_t>(from),
            a.begin() + static_cast<std::ptrdiff_t>(from + count));
}

// `per` consecutive elements per vertex (vertex-major), to the vertex's block.
inline void rows(BodyBytes& out, std::span<const std::byte> a, std::size_t elem, std::size_t per) {
  const std::size_t stride = elem * per;
  for (std::size_t i = 0; i * stride < a.size(); ++i) append(out.blocks[i / kernel::kBlock], a, i * stride, stride);
}

// Column-major, n vertices per column (entry s·n + i is vertex i's).
inline void columns(BodyBytes& out, std::span<const std::byte> a, std::size_t elem, std::size_t n) {
  for (std::size_t e = 0; e * elem < a.size(); ++e) append(out.blocks[(e % n) / kernel::kBlock], a, e * elem, elem);
}

// One element per block.
inline void per_block(BodyBytes& out, std::span<const std::byte> a, std::size_t elem) {
  for (std::size_t k = 0; k * elem < a.size(); ++k) append(out.blocks[k], a, k * elem, elem);
}

// Follows world_state.cpp's walk; every array's size is checked, so a field
// added to the state fails here until it is placed (and the block images
// told about it, if it belongs to a block).
template <class S>
std::vector<BodyBytes> split_state(std::span<const std::byte> bytes) {
  StateParser p(bytes);
  for (int k = 0; k < 8; ++k) p.value<char>();                // magic
  for (int k = 0; k < 5; ++k) p.value<std::uint32_t>();       // format, sizes
  const auto bodies = p.value<std::uint32_t>(), tool_slots = p.value<std::uint32_t>();
  std::vector<BodyBytes> out(bodies);
  constexpr std::size_t s = sizeof(S);
  for (BodyBytes& body : out) {
    const std::size_t n = p.value<std::uint32_t>(), blocks = p.value<std::uint32_t>();
    const auto cols = static_cast<std::size_t>(p.value<int>());
    body.blocks.resize(blocks);
    for (int k = 0; k < 12; ++k) rows(body, p.array(s, {n, 0}), s, 1);  // x y z, w, r, a (arrays path)
    columns(body, p.array(s, {cols * n, 0}), s, n);                     // rest lengths
    const auto overflow = p.array(sizeof(kernel::Overflow<S>), {});
    for (std::size_t o = 0; o * sizeof(kernel::Overflow<S>) < overflow.size(); ++o) {
      kernel::Overflow<S> rec;
      std::memcpy(&rec, overflow.data() + o * sizeof rec, sizeof rec);
      append(body.blocks[rec.i / kernel::kBlock], overflow, o * sizeof rec, sizeof rec);
    }
    const auto p0 = p.array(s, {8 * n, 0}), p1 = p.array(s, {8 * n, 0});
    const bool cur = p.value<std::int32_t>() != 0;
    rows(body, cur ? p1 : p0, s, 8);
    rows(body, cur ? p0 : p1, s, 8);
    p.array(8, {blocks, 0});  // ring stamps: a clock
    p.value<std::uint64_t>();  // ring epoch
    per_block(body, p.array(sizeof(BlockState<S>), {blocks}), sizeof(BlockState<S>));
    p.value_into<std::uint32_t>(body.derived);  // awake blocks
    p.value_into<std::array<S, 3>>(body.derived), p.value_into<std::array<S, 3>>(body.derived);  // box
    for (std::uint32_t t = 0; t < tool_slots; ++t) {  // grabs: the tool's
      p.array(sizeof(Grab<S>), {});
      p.value<std::uint32_t>(), p.value<std::uint8_t>();
    }
    for (int k = 0; k < 3; ++k) rows(body, p.array(2, {n}), 2, 1);  // checkpoint
    per_block(body, p.array(sizeof(CheckpointGrid<S>), {blocks}), sizeof(CheckpointGrid<S>));
    for (int k = 0; k < 3; ++k) rows(body, p.array(s, {n, 0}), s, 1);  // clay's checkpoint rest shape
    columns(body, p.array(s, {cols * n, 0}), s, n);
    p.value<double>(), p.value<double>(), p.value<std::uint64_t>();  // energies, blow-ups
    p.value<int>(), p.value<int>(), p.value<bool>();                 // boost, checkpoint age, input
  }
  return out;
}

}  // namespace sculpt::sim::test
