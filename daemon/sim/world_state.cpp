// World::state and World::restore_state: everything a tick reads that an
// earlier tick wrote, so a world built from the same scene continues from
// the bytes bit for bit. Scratch that every tick rewrites before reading it
// (awake lists, candidates, the ring's records, outcodes, feedback) is left out.
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstring>

#include "sim/blocks.hpp"
#include "sim/state_bytes.hpp"
#include "sim/stability.hpp"
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
  for (std::uint32_t g = 0; g < count; ++g) {
    if (grabs[g].i >= n)
      throw std::invalid_argument("state: a grab holds vertex " + std::to_string(grabs[g].i) + " of a mesh of " +
                                  std::to_string(n));
    // Sorted by vertex, each once (GrabSprings merges on that order).
    if (g > 0 && grabs[g].i <= grabs[g - 1].i) throw std::invalid_argument("state: a grab's vertices are out of order");
    const S o[3] = {grabs[g].ox, grabs[g].oy, grabs[g].oz};
    for (S v : o)
      if (!std::isfinite(v) || std::abs(v) > S(kStateMaxCoordinate))
        throw std::invalid_argument("state: a grab's offset is " + std::to_string(v));
  }
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
  arr(b.sx, "checkpoint"), arr(b.sy, "checkpoint"), arr(b.sz, "checkpoint"), arr(b.checkpoint_grid, "checkpoint grid");
  arr(b.srx, "checkpoint rest shape"), arr(b.sry, "checkpoint rest shape"), arr(b.srz, "checkpoint rest shape");
  arr(b.slen, "checkpoint rest lengths");
  val(b.energy, "energy"), val(b.energy_ref, "energy"), val(b.blowups, "blow-ups"), val(b.boost, "substep boost");
  val(b.checkpoint_age, "checkpoint age"), val(b.external_input, "input flag");
}

// The checks of a state's values (World::check_state), each naming what
// is wrong: which mesh, which array, which entry, the value and the bound.
template <class S>
class StateCheck {
 public:
  StateCheck(const StateView& view, std::uint32_t body) : v_(view), body_(body) {}

  [[noreturn]] void fail(const std::string& what) const {
    throw std::invalid_argument("state: mesh " + std::to_string(body_) + ": " + what);
  }
  static std::string num(double x) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.9g", x);
    return buf;
  }
  // Every element finite and within ±bound.
  template <class C>
  void finite(const C& a, const char* what, double bound) const {
    const auto in = v_.array(a);
    for (std::size_t i = 0; i < in.size(); ++i) {
      const double x = static_cast<double>(in[i]);
      if (!std::isfinite(x) || std::abs(x) > bound)
        fail(std::string(what) + "[" + std::to_string(i) + "] is " + num(x) + " (finite, within ±" + num(bound) + ")");
    }
  }
  // Bit for bit what the world has (what no step changes: the network, an elastic rest shape).
  template <class C>
  void same(const C& a, const char* what) const {
    const auto in = v_.array(a);
    for (std::size_t i = 0; i < in.size(); ++i)
      if (std::memcmp(in.element(i).data(), &a[i], sizeof a[i]) != 0)
        fail(std::string(what) + "[" + std::to_string(i) + "] is not the scene's (it never changes)");
  }
  void flag(std::span<const std::byte> bytes, std::size_t offset, const char* what) const {
    if (std::to_integer<unsigned>(bytes[offset]) > 1)
      fail(std::string(what) + " is " + std::to_string(std::to_integer<unsigned>(bytes[offset])) + ", not a flag");
  }
  template <class T>
  T value(const T& field) const { return v_.value(field); }
  template <class C>
  auto array(const C& a) const { return v_.array(a); }
  const StateView& view() const { return v_; }

 private:
  const StateView& v_;
  std::uint32_t body_;
};

template <class S>
void check_blocks(const StateCheck<S>& c, const Body<S>& b, int sleep_ticks) {
  const auto blocks = c.array(b.block);
  const double bound = kStateMaxCoordinate;
  for (std::uint32_t k = 0; k < b.blocks; ++k) {
    const std::span<const std::byte> raw = blocks.element(k);
    const std::string at = "block " + std::to_string(k);
    using B = BlockState<S>;
    for (std::size_t off : {offsetof(B, awake), offsetof(B, touched), offsetof(B, changed), offsetof(B, dirty),
                            offsetof(B, accel_current), offsetof(B, grabbed)})
      c.flag(raw, off, (at + " flag").c_str());
    const B s = blocks[k];
    for (int a = 0; a < 3; ++a) {
      if (!std::isfinite(s.lo[a]) || !std::isfinite(s.hi[a]) || std::abs(s.lo[a]) > bound || std::abs(s.hi[a]) > bound ||
          s.lo[a] > s.hi[a])
        c.fail(at + ": its box is [" + StateCheck<S>::num(s.lo[a]) + ", " + StateCheck<S>::num(s.hi[a]) + "]");
    }
    if (!std::isfinite(s.grow) || s.grow < 0 || s.grow > S(2 * bound))
      c.fail(at + ": grows by " + StateCheck<S>::num(s.grow));
    if (std::memcmp(&s.reach, &b.block[k].reach, sizeof s.reach) != 0) c.fail(at + ": its reach is not the scene's");
    if (!std::isfinite(s.energy)) c.fail(at + ": its energy is " + StateCheck<S>::num(s.energy));
    if (s.quiet_ticks < 0 || s.quiet_ticks > sleep_ticks)
      c.fail(at + ": quiet for " + std::to_string(s.quiet_ticks) + " ticks (0 to " + std::to_string(sleep_ticks) + ")");
    // Its vertices within its box; at rest if it sleeps (sleeping zeroes them).
    const auto x = c.array(b.x), y = c.array(b.y), z = c.array(b.z);
    const auto wx = c.array(b.wx), wy = c.array(b.wy), wz = c.array(b.wz);
    const bool awake = std::to_integer<unsigned>(raw[offsetof(B, awake)]) != 0;
    for (std::uint32_t i = b.begin_of(k); i < b.end_of(k); ++i) {
      const double p[3] = {static_cast<double>(x[i]), static_cast<double>(y[i]), static_cast<double>(z[i])};
      for (int a = 0; a < 3; ++a)
        if (!within_block_box(s, a, p[a]))
          c.fail("vertex " + std::to_string(i) + " is at " + StateCheck<S>::num(p[a]) + " on axis " + std::to_string(a) +
                 ", outside its block's box [" + StateCheck<S>::num(s.lo[a]) + ", " + StateCheck<S>::num(s.hi[a]) +
                 "] grown by " + StateCheck<S>::num(s.grow));
      if (!awake && (wx[i] != S(0) || wy[i] != S(0) || wz[i] != S(0)))
        c.fail("vertex " + std::to_string(i) + " moves in " + at + ", which sleeps");
    }
  }
}

// The spring rest lengths: padding entries (offset 0) and every entry of an
// elastic body are the scene's; clay's yield, finite and not negative.
template <class S>
void check_rest_lengths(const StateCheck<S>& c, const Body<S>& b) {
  const auto rest = c.array(b.rest_length);
  for (std::size_t e = 0; e < rest.size(); ++e) {
    const S r = rest[e];
    if (!b.plastic || b.nbr[e] == 0) {
      if (std::memcmp(&r, &b.rest_length[e], sizeof r) != 0)
        c.fail("rest length " + std::to_string(e) + " is " + StateCheck<S>::num(r) + ", the scene's " +
               StateCheck<S>::num(b.rest_length[e]) + " (it never changes)");
    } else if (!std::isfinite(r) || r < 0 || r > S(2 * kStateMaxCoordinate)) {
      c.fail("rest length " + std::to_string(e) + " is " + StateCheck<S>::num(r));
    }
  }
  const auto over = c.array(b.overflow);
  for (std::size_t o = 0; o < over.size(); ++o) {
    const kernel::Overflow<S> x = over[o], want = b.overflow[o];
    if (x.i != want.i || x.j != want.j || x.far != want.far)
      c.fail("overflow spring " + std::to_string(o) + " joins vertices " + std::to_string(x.i) + " and " +
             std::to_string(x.j) + " (far " + std::to_string(x.far) + "), the scene's " + std::to_string(want.i) +
             " and " + std::to_string(want.j) + " (far " + std::to_string(want.far) + ")");
    if (!b.plastic) {
      if (std::memcmp(&x.rest_length, &want.rest_length, sizeof x.rest_length) != 0)
        c.fail("overflow spring " + std::to_string(o) + " has rest length " + StateCheck<S>::num(x.rest_length) +
               ", the scene's " + StateCheck<S>::num(want.rest_length) + " (it never changes)");
    } else if (!std::isfinite(x.rest_length) || x.rest_length < 0 || x.rest_length > S(2 * kStateMaxCoordinate)) {
      c.fail("overflow spring " + std::to_string(o) + " has rest length " + StateCheck<S>::num(x.rest_length));
    }
  }
}

// Velocities within what the guard lets a tick keep (a vertex faster than
// speed_limit is divergence, sim/substep.hpp), with room for rounding;
// packed records as the kernels write them.
template <class S>
void check_motion(const StateCheck<S>& c, const Body<S>& b, double dts) {
  const double limit = kStateSpeedMargin * b.speed_limit;
  const auto wx = c.array(b.wx), wy = c.array(b.wy), wz = c.array(b.wz);
  const double per = b.velocity == kernel::Velocity::step ? 1.0 / dts : 1.0;
  for (std::uint32_t i = 0; i < b.n; ++i) {
    const double v[3] = {wx[i] * per, wy[i] * per, wz[i] * per};
    const double speed = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(speed <= limit))
      c.fail("vertex " + std::to_string(i) + " moves at " + StateCheck<S>::num(speed) + " m/s, over the " +
             StateCheck<S>::num(limit) + " m/s a tick keeps");
  }
  for (int k = 0; k < 2; ++k) {
    const auto q = c.array(b.packed[k]);
    for (std::size_t i = 0; i < q.size(); ++i) {
      const double x = static_cast<double>(q[i]);
      const std::size_t slot = i % 8;
      const bool ok = slot == 3 || slot == 7 ? x == 0.0
                      : slot < 3             ? std::isfinite(x) && std::abs(x) <= 2 * kStateMaxCoordinate
                                             : std::isfinite(x) && std::abs(x) <= limit;
      if (!ok)
        c.fail("packed record " + std::to_string(i / 8) + "[" + std::to_string(slot) + "] is " + StateCheck<S>::num(x));
    }
  }
}

}  // namespace

// Plausibility: what the dry pass found, value by value, against what a
// world of this scene can be in. What never changes (the network, an elastic
// body's rest shape, the blocks' reach) must be the scene's bit for bit;
// what the step changes must be finite, within kStateMaxCoordinate of the
// origin (the tools' own bound), moving no faster than the guard allows,
// and flags and enums one of their values. Throws std::invalid_argument
// naming the mesh, the field, the entry and the value.
template <class S>
void World<S>::check_state(const StateView& view) const {
  for (std::uint32_t bi = 0; bi < bodies_.size(); ++bi) {
    const Body<S>& b = bodies_[bi];
    const StateCheck<S> c(view, bi);
    const int boost = c.value(b.boost);
    if (boost < 1 || boost > kMaxSubstepBoost || (boost & (boost - 1)) != 0)
      c.fail("substep boost " + std::to_string(boost) + " (a power of two up to " + std::to_string(kMaxSubstepBoost) +
             ")");
    const double bound = kStateMaxCoordinate;
    c.finite(b.x, "x", bound), c.finite(b.y, "y", bound), c.finite(b.z, "z", bound);
    if (b.plastic) {
      c.finite(b.rx, "rest x", bound), c.finite(b.ry, "rest y", bound), c.finite(b.rz, "rest z", bound);
    } else {
      c.same(b.rx, "rest x"), c.same(b.ry, "rest y"), c.same(b.rz, "rest z");
    }
    c.finite(b.wx, "velocity x", HUGE_VAL), c.finite(b.wy, "velocity y", HUGE_VAL), c.finite(b.wz, "velocity z", HUGE_VAL);
    c.finite(b.ax, "acceleration x", HUGE_VAL), c.finite(b.ay, "acceleration y", HUGE_VAL);
    c.finite(b.az, "acceleration z", HUGE_VAL);
    const int nsub = std::min(kMaxSubsteps, base_substeps_[bi] * boost);
    check_motion(c, b, 1.0 / settings_.rate_hz / nsub);
    check_rest_lengths(c, b);
    const auto stamps = c.array(b.ring_stamp);
    const std::uint64_t epoch = c.value(b.ring_epoch);
    for (std::size_t k = 0; k < stamps.size(); ++k)
      if (stamps[k] > epoch)
        c.fail("block " + std::to_string(k) + " was packed in ring epoch " + std::to_string(stamps[k]) +
               ", after the body's " + std::to_string(epoch));
    check_blocks(c, b, settings_.sleep_ticks);
    for (const auto* box : {&b.lo, &b.hi}) {
      const std::array<S, 3> v = c.value(*box);
      for (S x : v)
        if (!std::isfinite(x)) c.fail("its box is not finite");
    }
    const auto grid = c.array(b.checkpoint_grid);
    for (std::size_t k = 0; k < grid.size(); ++k) {
      const CheckpointGrid<S> g = grid[k];
      for (int a = 0; a < 3; ++a)
        if (!std::isfinite(g.lo[a]) || std::abs(g.lo[a]) > S(bound) || !std::isfinite(g.step[a]) || g.step[a] < 0 ||
            g.step[a] > S(bound))
          c.fail("the guard's grid of block " + std::to_string(k) + " is not within the world");
    }
    c.finite(b.srx, "saved rest x", bound), c.finite(b.sry, "saved rest y", bound);
    c.finite(b.srz, "saved rest z", bound), c.finite(b.slen, "saved rest length", 2 * bound);
    const double energy = c.value(b.energy), energy_ref = c.value(b.energy_ref);
    if (!std::isfinite(energy) || !std::isfinite(energy_ref))
      c.fail("its energy is " + StateCheck<S>::num(energy) + " (reference " + StateCheck<S>::num(energy_ref) + ")");
    if (c.value(b.checkpoint_age) < 0) c.fail("the guard's checkpoint age is negative");
    c.flag(view.bytes_of(&b.external_input), 0, "the input flag");
  }
  const auto tracks = view.array(tracks_);
  for (std::size_t t = 0; t < tracks.size(); ++t) {
    const std::string at = "state: tool " + std::to_string(t);
    const std::span<const std::byte> raw = tracks.element(t);
    using T = ToolTrack<S>;
    for (std::size_t off : {offsetof(T, active), offsetof(T, known), offsetof(T, grab), offsetof(T, grab_prev)})
      if (std::to_integer<unsigned>(raw[off]) > 1) throw std::invalid_argument(at + ": a flag is not a flag");
    std::underlying_type_t<ToolShape> shape;
    std::memcpy(&shape, raw.data() + offsetof(T, shape), sizeof shape);
    if (shape != static_cast<int>(ToolShape::sphere) && shape != static_cast<int>(ToolShape::capsule))
      throw std::invalid_argument(at + ": shape " + std::to_string(shape));
    const T tr = tracks[t];
    bool ok = std::isfinite(tr.radius) && tr.radius >= 0 && tr.radius < S(1e3);
    for (const Vec3d* v : {&tr.c0, &tr.c1, &tr.a0, &tr.a1})
      for (double x : *v) ok = ok && std::isfinite(x) && std::abs(x) <= kStateMaxCoordinate;
    for (int a = 0; a < 3; ++a) ok = ok && std::isfinite(tr.lo[a]) && std::isfinite(tr.hi[a]);
    if (!ok) throw std::invalid_argument(at + ": its pose is not within the world");
  }
  const std::uint32_t last = view.value(last_blowup_body_);
  if (last > 0 && last >= bodies_.size())
    throw std::invalid_argument("state: the last blow-up was of mesh " + std::to_string(last) + ", the scene has " +
                                std::to_string(bodies_.size()));
  const auto cause = view.bytes_of(&last_blowup_cause_);
  if (std::to_integer<unsigned>(cause[0]) > static_cast<unsigned>(BlowupCause::energy_growth))
    throw std::invalid_argument("state: blow-up cause " + std::to_string(std::to_integer<unsigned>(cause[0])));
}

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
  StateView view;
  StateReader check(bytes, /*dry=*/true);
  check.note_to(&view);
  read_state(check);
  check_state(view);  // the values, before any of them is written
  close_strokes();  // their images are of the state being replaced
  for (auto& e : recorders_) e->forget_exchanges();
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
template void World<float>::check_state(const StateView&) const;
template void World<double>::check_state(const StateView&) const;

}  // namespace sculpt::sim
