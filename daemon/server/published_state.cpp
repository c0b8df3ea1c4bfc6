#include "server/published_state.hpp"

#include <algorithm>
#include <bit>
#include <cstring>
#include <limits>

namespace sculpt::server {

PublishedState::PublishedState(const sim::World<float>& world, double rate_hz, std::uint64_t first_tick)
    : rate_hz_(rate_hz) {
  bodies_.resize(world.body_count());
  for (std::size_t i = 0; i < bodies_.size(); ++i) {
    const auto& body = world.body(i);
    Body& b = bodies_[i];
    b.layout.n = body.n;
    b.layout.blocks = (body.n + kBlock - 1) / kBlock;
    b.layout.to_original = body.to_original;
    b.xyz = std::make_unique<std::atomic<std::uint32_t>[]>(std::size_t{body.n} * 3);
    b.seq = std::make_unique<BlockSeq[]>(b.layout.blocks);
    for (std::uint32_t k = 0; k < b.layout.blocks; ++k) write_block(b, body, k);
  }
  PublishedHeader h;
  h.tick = world.tick() + first_tick;
  header_.store(h);
}

void PublishedState::start_at(std::uint64_t first_tick) {
  PublishedHeader h = header_.load();
  h.tick = first_tick;
  header_.store(h);
}

void PublishedState::write_block(Body& b, const sim::Body<float>& body, std::uint32_t block) {
  const std::uint32_t begin = block * kBlock;
  const std::uint32_t end = std::min(b.layout.n, begin + kBlock);
  auto& seq = b.seq[block].seq;
  const std::uint64_t s = seq.load(std::memory_order_relaxed);
  seq.store(s + 1, std::memory_order_relaxed);  // odd: being written
  std::atomic_thread_fence(std::memory_order_release);
  std::atomic<std::uint32_t>* out = &b.xyz[std::size_t{begin} * 3];
  for (std::uint32_t i = begin; i < end; ++i, out += 3) {
    out[0].store(std::bit_cast<std::uint32_t>(body.x[i]), std::memory_order_relaxed);
    out[1].store(std::bit_cast<std::uint32_t>(body.y[i]), std::memory_order_relaxed);
    out[2].store(std::bit_cast<std::uint32_t>(body.z[i]), std::memory_order_relaxed);
  }
  seq.store(s + 2, std::memory_order_release);
}

void PublishedState::publish(std::uint64_t tick, const sim::World<float>& world, std::span<const sim::Tool> tools,
                             std::int64_t now_ns) {
  for (const sim::ChangeRange& r : world.changes()) {
    if (r.body >= bodies_.size() || r.begin >= r.end) continue;
    Body& b = bodies_[r.body];
    const auto& body = world.body(r.body);
    const std::uint32_t last = std::min(r.end, b.layout.n);
    if (r.begin >= last) continue;
    for (std::uint32_t k = r.begin / kBlock; k <= (last - 1) / kBlock; ++k) write_block(b, body, k);
  }
  PublishedHeader h;
  h.tick = tick + 1;
  h.published_ns = now_ns;
  h.awake_vertices = world.stats().awake_vertices;
  const auto feedback = world.feedback();
  h.tool_count = static_cast<std::uint32_t>(std::min(tools.size(), sim::kMaxTools));
  for (std::size_t t = 0; t < h.tool_count; ++t) {
    const sim::Tool& in = tools[t];
    PublishedTool& o = h.tools[t];
    o.active = in.active;
    o.grab = in.grab;
    o.shape = static_cast<std::uint8_t>(in.shape);
    o.radius = static_cast<float>(in.radius);
    for (int a = 0; a < 3; ++a) {
      o.position[a] = static_cast<float>(in.position[a]);
      o.half_axis[a] = static_cast<float>(in.half_axis[a]);
      o.velocity[a] = static_cast<float>(in.velocity[a]);
    }
    if (t < feedback.size()) {
      for (int a = 0; a < 3; ++a) o.force[a] = static_cast<float>(feedback[t].force[a]);
      o.contacts = feedback[t].contacts;
    }
  }
  header_.store(h);
}

PublishedReader::PublishedReader(const PublishedState& state) : state_(state) {
  bodies_.resize(state.body_count());
  for (std::size_t i = 0; i < bodies_.size(); ++i) {
    const auto& l = state.layout(i);
    Body& b = bodies_[i];
    b.positions.assign(std::size_t{l.n} * 3, 0.0f);
    b.seen.assign(l.blocks, std::numeric_limits<std::uint64_t>::max());
    b.serial.assign(l.blocks, 0);
    b.scratch.resize(std::size_t{kBlock} * 3);
  }
  sync();
}

std::span<const std::uint32_t> PublishedReader::block_vertices(std::size_t b, std::uint32_t block) const {
  const auto& l = state_.layout(b);
  const std::uint32_t begin = block * kBlock;
  const std::uint32_t end = std::min(l.n, begin + kBlock);
  return std::span<const std::uint32_t>(l.to_original).subspan(begin, end - begin);
}

const std::array<float, 6>& PublishedReader::bounds(std::size_t b) const {
  const Body& body = bodies_[b];
  if (body.bounds_stale) {
    std::array<float, 6> bb{0, 0, 0, 0, 0, 0};
    const auto& p = body.positions;
    for (std::size_t i = 0; i < p.size(); i += 3)
      for (int a = 0; a < 3; ++a) {
        if (i == 0 || p[i + a] < bb[a]) bb[a] = p[i + a];
        if (i == 0 || p[i + a] > bb[3 + a]) bb[3 + a] = p[i + a];
      }
    body.bounds = bb;
    body.bounds_stale = false;
  }
  return body.bounds;
}

const PublishedHeader& PublishedReader::sync() {
  // The header first: every block the sim wrote up to that tick is visible
  // below, so what we copy is at least as new as it.
  const PublishedHeader h = state_.header_.load();
  ++serial_;
  for (std::size_t bi = 0; bi < bodies_.size(); ++bi) {
    const PublishedState::Body& src = state_.bodies_[bi];
    Body& dst = bodies_[bi];
    bool changed = false;
    for (std::uint32_t k = 0; k < src.layout.blocks; ++k) {
      const std::uint64_t s0 = src.seq[k].seq.load(std::memory_order_acquire);
      if (s0 == dst.seen[k]) continue;
      if (s0 & 1) {
        ++torn_;
        continue;  // being written: next pass
      }
      const std::uint32_t begin = k * kBlock;
      const std::uint32_t end = std::min(src.layout.n, begin + kBlock);
      const std::atomic<std::uint32_t>* in = &src.xyz[std::size_t{begin} * 3];
      const std::size_t words = std::size_t{end - begin} * 3;
      for (std::size_t w = 0; w < words; ++w)
        dst.scratch[w] = std::bit_cast<float>(in[w].load(std::memory_order_relaxed));
      std::atomic_thread_fence(std::memory_order_acquire);
      if (src.seq[k].seq.load(std::memory_order_relaxed) != s0) {
        ++torn_;
        continue;
      }
      const auto& orig = src.layout.to_original;
      for (std::uint32_t i = begin; i < end; ++i)
        std::memcpy(&dst.positions[std::size_t{orig[i]} * 3], &dst.scratch[std::size_t{i - begin} * 3], 12);
      dst.seen[k] = s0;
      dst.serial[k] = serial_;
      changed = true;
    }
    if (changed) dst.bounds_stale = true;
  }
  header_ = h;
  return header_;
}

}  // namespace sculpt::server
