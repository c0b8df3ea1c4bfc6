// World::state and World::restore_state: everything a tick reads that an
// earlier tick wrote, so a world built from the same scene continues from
// the bytes bit for bit. Scratch that every tick rewrites before reading it
// (awake lists, candidates, the ring's records, outcodes, feedback) is left out.
#include <cstring>

#include "sim/state_bytes.hpp"
#include "sim/world.hpp"

namespace sculpt::sim {

namespace {

constexpr char kMagic[8] = {'s', 'c', 'u', 'l', 'p', 't', 's', 't'};
constexpr std::uint32_t kFormat = 1;

// What a reader must agree on before any array: the format, the precision
// and the layout of the records copied whole.
template <class S>
struct StateHeader {
  char magic[8];
  std::uint32_t format = kFormat;
  std::uint32_t scalar_bytes = sizeof(S);
  std::uint32_t block_bytes = sizeof(BlockState<S>);
  std::uint32_t track_bytes = sizeof(ToolTrack<S>);
  std::uint32_t grab_bytes = sizeof(Grab<S>);
  std::uint32_t bodies = 0;
  std::uint32_t tool_slots = 0;
};

// A tool's grab, checked in both passes (the vertices it holds exist) and
// written in the real one.
template <class S>
void read_grabs(StateReader& r, ToolContact<S>& tc, std::uint32_t n) {
  std::vector<Grab<S>> grabs(tc.grabs.size());
  r.array(std::span<Grab<S>>(grabs), "grabs", /*always=*/true);
  std::uint32_t count = 0;
  std::uint8_t grabbing = 0;
  r.value(count, "grabs"), r.value(grabbing, "grabs");
  if (count > grabs.size() || grabbing > 1) throw std::invalid_argument("state: a tool's grab is out of range");
  for (std::uint32_t g = 0; g < count; ++g)
    if (grabs[g].i >= n) throw std::invalid_argument("state: a grab holds a vertex out of range");
  if (r.dry()) return;
  std::copy(grabs.begin(), grabs.end(), tc.grabs.begin());
  tc.grab_count = count;
  tc.grabbing = grabbing != 0;
}

template <class S>
void read_packed_cur(StateReader& r, BodyRecords<S>& rec) {
  std::int32_t cur = 0;
  r.value(cur, "packed records");
  if (cur != 0 && cur != 1) throw std::invalid_argument("state: packed records out of range");
  if (!r.dry()) rec.packed_cur = cur;
}

// The same walk for both directions: Io is StateWriter or StateReader.
template <class S, class Io, class B>
void body_state(Io& io, B& b) {
  auto arr = [&io](auto& a, const char* what) {
    if constexpr (std::is_same_v<Io, StateWriter>) io.array(a);
    else io.array(a, what);
  };
  auto val = [&io](auto& v, const char* what) {
    if constexpr (std::is_same_v<Io, StateWriter>) io.value(v);
    else io.field(v, what);
  };
  arr(b.x, "x"), arr(b.y, "y"), arr(b.z, "z");
  arr(b.wx, "wx"), arr(b.wy, "wy"), arr(b.wz, "wz");
  arr(b.rx, "rx"), arr(b.ry, "ry"), arr(b.rz, "rz");
  arr(b.ax, "ax"), arr(b.ay, "ay"), arr(b.az, "az");
  arr(b.rest_length, "rest lengths"), arr(b.overflow, "overflow springs");
  arr(b.packed[0], "packed records"), arr(b.packed[1], "packed records");
  if constexpr (std::is_same_v<Io, StateWriter>) io.value(static_cast<std::int32_t>(b.packed_cur));
  else read_packed_cur(io, b);
  arr(b.ring_stamp, "ring stamps"), val(b.ring_epoch, "ring epoch");
  arr(b.block, "blocks"), val(b.awake_blocks, "awake blocks"), val(b.lo, "box"), val(b.hi, "box");
  for (auto& tc : b.tools) {
    if constexpr (std::is_same_v<Io, StateWriter>)
      io.array(tc.grabs), io.value(tc.grab_count), io.value(static_cast<std::uint8_t>(tc.grabbing));
    else
      read_grabs(io, tc, b.n);
  }
  arr(b.sx, "snapshot"), arr(b.sy, "snapshot"), arr(b.sz, "snapshot"), arr(b.snapshot_grid, "snapshot grid");
  arr(b.srx, "snapshot rest shape"), arr(b.sry, "snapshot rest shape"), arr(b.srz, "snapshot rest shape");
  arr(b.slen, "snapshot rest lengths");
  val(b.energy, "energy"), val(b.energy_ref, "energy"), val(b.blowups, "blow-ups"), val(b.boost, "substep boost");
  val(b.snapshot_age, "snapshot age"), val(b.external_input, "input flag");
}

}  // namespace

template <class S>
std::vector<std::byte> World<S>::state() const {
  std::vector<std::byte> out;
  StateWriter w(out);
  StateHeader<S> h;
  std::memcpy(h.magic, kMagic, sizeof kMagic);
  h.bodies = static_cast<std::uint32_t>(bodies_.size());
  h.tool_slots = tool_slots_;
  w.value(h);
  for (const Body<S>& b : bodies_) {
    w.value(b.n), w.value(b.blocks), w.value(b.columns);
    body_state<S>(w, b);
  }
  w.array(tracks_);
  w.value(tick_), w.value(blowups_total_), w.value(last_blowup_body_), w.value(last_blowup_cause_);
  return out;
}

template <class S>
void World<S>::restore_state(std::span<const std::byte> bytes) {
  StateReader check(bytes, /*dry=*/true);
  read_state(check);
  close_edits();  // their images are of the state being replaced
  for (auto& e : edits_) e->forget_swaps();
  StateReader r(bytes, /*dry=*/false);
  read_state(r);
  for (Body<S>& b : bodies_) {
    b.awake_blocks = 0;
    for (const BlockState<S>& s : b.block) b.awake_blocks += s.awake;
  }
}

template <class S>
void World<S>::read_state(StateReader& r) {
  StateHeader<S> h, want;
  r.value(h, "header");
  if (std::memcmp(h.magic, kMagic, sizeof kMagic) != 0) throw std::invalid_argument("state: not a world state");
  if (h.format != want.format)
    throw std::invalid_argument("state: format " + std::to_string(h.format) + ", this build reads " +
                                std::to_string(kFormat));
  if (h.scalar_bytes != want.scalar_bytes || h.block_bytes != want.block_bytes || h.track_bytes != want.track_bytes ||
      h.grab_bytes != want.grab_bytes)
    throw std::invalid_argument("state: written by another precision or build");
  if (h.bodies != bodies_.size() || h.tool_slots != tool_slots_)
    throw std::invalid_argument("state: " + std::to_string(h.bodies) + " meshes and " + std::to_string(h.tool_slots) +
                                " tools, the scene " + std::to_string(bodies_.size()) + " and " +
                                std::to_string(tool_slots_));
  for (Body<S>& b : bodies_) {
    std::uint32_t n = b.n, blocks = b.blocks;
    int columns = b.columns;
    r.value(n, "mesh size"), r.value(blocks, "mesh size"), r.value(columns, "mesh size");
    if (n != b.n || blocks != b.blocks || columns != b.columns)
      throw std::invalid_argument("state: a mesh of " + std::to_string(n) + " vertices, the scene's has " +
                                  std::to_string(b.n));
    body_state<S>(r, b);
  }
  r.array(tracks_, "tools");
  r.field(tick_, "tick"), r.field(blowups_total_, "blow-ups"), r.field(last_blowup_body_, "blow-ups");
  r.field(last_blowup_cause_, "blow-ups");
  if (!r.done()) throw std::invalid_argument("state: bytes left over after the last field");
}

template std::vector<std::byte> World<float>::state() const;
template std::vector<std::byte> World<double>::state() const;
template void World<float>::restore_state(std::span<const std::byte>);
template void World<double>::restore_state(std::span<const std::byte>);
template void World<float>::read_state(StateReader&);
template void World<double>::read_state(StateReader&);

}  // namespace sculpt::sim
