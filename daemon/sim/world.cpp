// World: the tick as a list of stages. Per tick: read the tools; per body:
// find contacts (broadphase), then each substep the body's stepper (forces,
// grab springs, clay's yield, integration), the narrow phase and the pins;
// then the guard judges the tick, quiet blocks sleep, and the changed blocks
// are logged; finally the tools get their feedback.
#include "sim/world.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "sim/blocks.hpp"
#include "sim/clay.hpp"
#include "sim/guard.hpp"
#include "sim/motion.hpp"
#include "sim/stability.hpp"

namespace sculpt::sim {

namespace {

using kernel::kBlock;

constexpr int kCheckpointInterval = 32;  // ticks between good-state checkpoints of moving blocks
constexpr double kEnergyGrowth = 4.0;  // energy may fluctuate (Verlet's measured energy wobbles) but not 4×

bool finite3(const Vec3d& v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }
double norm(const Vec3d& v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

// Energy the guard will not call a blow-up: a mesh barely moving, plus 1% strain on every spring.
template <class S>
double energy_floor(const Body<S>& b, double g) {
  const double m = b.material.mass;
  return b.n * m * (0.5 * 0.05 * 0.05 + g * b.extent) +
         b.springs * b.material.stiffness * (0.01 * b.mean_edge) * (0.01 * b.mean_edge) + 1e-12;
}

// Pinned vertices back where they are held, at rest.
template <class S>
void apply_pins(Body<S>& b, std::uint32_t blk, S inv_dt) {
  for (std::uint32_t p = b.pinned_begin[blk]; p < b.pinned_begin[blk + 1]; ++p) {
    const Pinned<S>& pin = b.pinned[p];
    b.x[pin.i] = pin.x, b.y[pin.i] = pin.y, b.z[pin.i] = pin.z;
    b.wx[pin.i] = b.wy[pin.i] = b.wz[pin.i] = S(0);
    sync_records(b, pin.i, inv_dt);  // neighbours reading the records see the pin too
  }
}

}  // namespace

template <class S>
World<S>::World(const SimSettings& settings, int tool_slots)
    : settings_(settings),
      tool_slots_(static_cast<std::uint32_t>(std::clamp(tool_slots, 0, 64))),
      grabs_(tool_slots_) {
  validate(settings_);
  if (tool_slots < 0 || tool_slots > 64) throw std::invalid_argument("simulation: tool slots must be in [0, 64]");
  tracks_.resize(tool_slots_);
  feedback_.resize(tool_slots_);
  scratch_.resize(3 * std::size_t{kBlock});
}

template <class S>
std::uint32_t World<S>::add_body(const TriangleMesh& mesh, const Material& material, const BodyOptions& options) {
  // The ring runs where the AVX2 kernels do (the compiler's clones of it are
  // slower than gathering from the arrays) and for the integrators that step
  // in one pass. make_body builds its tables only if asked.
  const bool avx2 = kernel::avx2_paths_active();
  BodyOptions body_options = options;
  body_options.ring = options.ring && settings_.integrator != Integrator::velocity_verlet && avx2;
  Body<S> b = make_body<S>(mesh, material, body_options, static_cast<int>(tool_slots_));
  b.velocity = velocity_kind(settings_.integrator);
  const SubstepChoice choice = choose_substeps_for_degree(b.max_degree, material, settings_);
  const double g = material.gravity ? norm(settings_.gravity) : 0.0;
  b.energy_floor = energy_floor(b, g);
  // Nothing a hand does moves a vertex at ten times the fastest tool, and no
  // motion of the network itself beats its stiffest mode swinging across the
  // whole mesh (ω_max · extent: light vertices on stiff springs legitimately
  // move far faster than any tool). Anything faster is divergence.
  b.speed_limit = std::max(10.0 * settings_.max_tool_speed, std::sqrt(choice.bound.lambda_max_bound) * b.extent);
  // At rest pose with no gravity a mesh is in equilibrium: it starts asleep.
  if (material.gravity && g > 0.0)
    for (std::uint32_t blk = 0; blk < b.blocks; ++blk) wake_block(b, blk);
  update_box(b);
  const StepPath path = choose_step_path(b, settings_.integrator, avx2);
  if (path == StepPath::arrays)
    for (auto* buf : {&b.ax, &b.ay, &b.az}) buf->resize(b.n, S(0), &b.arena);
  b.arena.trim();  // every array is in place
  if (path == StepPath::ring && ring_.size() < 8 * std::size_t{b.ring_blocks} * kBlock)
    ring_.resize(8 * std::size_t{b.ring_blocks} * kBlock);
  // Scratch for the largest body so far: only this body can raise a size.
  potential_.resize(std::max<std::size_t>(potential_.size(), b.blocks));
  narrow_.reserve(b.n, b.blocks);
  if (b.plastic) yield_masks_.resize(std::max(yield_masks_.size(), clay_mask_bytes(b) * b.blocks));
  changes_.resize(changes_.size() + b.blocks);
  recorders_.push_back(std::make_unique<StrokeRecorder<S>>(static_cast<std::uint32_t>(bodies_.size()), b));
  recorders_.back()->set_sink(stroke_sink_);
  b.strokes = recorders_.back().get();
  steppers_.push_back(make_stepper<S>(path));
  paths_.push_back(path);
  base_substeps_.push_back(choice.substeps);
  bodies_.push_back(std::move(b));
  return static_cast<std::uint32_t>(bodies_.size() - 1);
}

template <class S>
int World<S>::substeps(std::size_t i) const {
  return std::min(kMaxSubsteps, base_substeps_[i] * bodies_[i].boost);
}

template <class S>
void World<S>::step(std::span<const Tool> tools) {
  ++tick_;
  stats_ = {};
  change_count_ = 0;
  collision_ns_ = 0;
  read_tools(tools);
  for (std::uint32_t bi = 0; bi < bodies_.size(); ++bi) step_body(bi);
  report_tools();
}

// Each tool's sweep this tick: from where it was to where it is now.
template <class S>
void World<S>::read_tools(std::span<const Tool> tools) {
  const double dt = 1.0 / settings_.rate_hz;
  for (std::uint32_t t = 0; t < tool_slots_; ++t) {
    ToolTrack<S>& tr = tracks_[t];
    ToolFeedback& fb = feedback_[t];
    fb = {};
    tr.force = {};
    tr.contacts = 0;
    const Tool none{.active = false};
    const Tool& in = t < tools.size() ? tools[t] : none;
    const bool valid = in.active && std::isfinite(in.radius) && in.radius > 0.0 && in.radius < 1e3 &&
                       finite3(in.position) && finite3(in.half_axis) && finite3(in.velocity) &&
                       norm(in.position) < 1e6 && norm(in.half_axis) < 1e3;
    if (in.active && !valid) {
      fb.ignored = true;
      ++stats_.ignored_tools;
    }
    if (!valid) {
      tr.active = tr.known = tr.grab = tr.grab_prev = false;
      tr.prev_contacts = 0;
      continue;
    }
    tr.active = true;
    tr.shape = in.shape;
    tr.radius = static_cast<S>(in.radius);
    tr.c1 = in.position;
    tr.a1 = in.shape == ToolShape::capsule ? in.half_axis : Vec3d{};
    if (!tr.known) {
      const double speed = norm(in.velocity);
      for (int k = 0; k < 3; ++k)
        tr.c0[k] = speed <= settings_.max_tool_speed ? tr.c1[k] - in.velocity[k] * dt : tr.c1[k];
      tr.a0 = tr.a1;
    }
    // Faster than any hand: a teleport (re-centring, a new scene). No sweep, no dragging.
    const double moved = std::max(norm({tr.c1[0] - tr.c0[0], tr.c1[1] - tr.c0[1], tr.c1[2] - tr.c0[2]}),
                                  norm({tr.a1[0] - tr.a0[0], tr.a1[1] - tr.a0[1], tr.a1[2] - tr.a0[2]}));
    if (moved > settings_.max_tool_speed * dt) {
      tr.c0 = tr.c1;
      tr.a0 = tr.a1;
    }
    tr.grab_prev = tr.grab;
    tr.grab = in.grab;
    for (int k = 0; k < 3; ++k) {
      const double e = std::max(std::abs(tr.a0[k]), std::abs(tr.a1[k])) + in.radius;
      tr.lo[k] = static_cast<S>(std::min(tr.c0[k], tr.c1[k]) - e);
      tr.hi[k] = static_cast<S>(std::max(tr.c0[k], tr.c1[k]) + e);
    }
  }
  // More tools than tool slots: the extra ones are ignored, and counted.
  if (tools.size() > tool_slots_) stats_.ignored_tools += static_cast<std::uint32_t>(tools.size() - tool_slots_);
}

template <class S>
void World<S>::report_tools() {
  const double dt = 1.0 / settings_.rate_hz;
  for (std::uint32_t t = 0; t < tool_slots_; ++t) {
    ToolTrack<S>& tr = tracks_[t];
    ToolFeedback& fb = feedback_[t];
    if (!tr.active) continue;
    if (finite3(tr.force)) fb.force = tr.force;
    fb.contacts = tr.contacts;
    fb.onset = tr.contacts > 0 && tr.prev_contacts == 0;
    if (fb.onset) fb.onset_impulse = norm(fb.force) * dt;
    tr.prev_contacts = tr.contacts;
    stats_.contacts += tr.contacts;
    tr.c0 = tr.c1;
    tr.a0 = tr.a1;
    tr.known = true;
  }
  stats_.blowups_total = blowups_total_;
  stats_.last_blowup_body = last_blowup_body_;
  stats_.last_blowup_cause = last_blowup_cause_;
}

template <class S>
void World<S>::step_body(std::uint32_t bi) {
  Body<S>& b = bodies_[bi];
  StrokeRecorder<S>& strokes = *recorders_[bi];
  find_contacts(bi);
  if (b.awake_blocks == 0) {  // the whole mesh sleeps: it costs this much
    if (strokes.exchanged_any()) log_changes(bi);  // blocks an exchange changed while it slept
    strokes.end_tick(b, tick_);
    return;
  }
  Substep<S> s = begin_tick(bi);
  for (; s.index < s.count; ++s.index) {
    grabs_.begin(b, tracks_, double(s.index) / s.count, s.count);
    steppers_[bi]->substep(s);
    resolve_contacts(b, s);
    if (!b.pinned.empty())
      for (std::uint32_t q = 0; q < b.awake_count; ++q) apply_pins(b, b.awake_list[q], S(1) / s.dt);
  }
  s.index = s.count - 1;
  steppers_[bi]->end_tick(s);
  const std::uint32_t awake_before = stats_.awake_vertices;
  for (std::uint32_t q = 0; q < b.awake_count; ++q)
    stats_.awake_vertices += b.end_of(b.awake_list[q]) - b.begin_of(b.awake_list[q]);
  stats_.awake_blocks += b.awake_count;
  stats_.vertex_steps += std::uint64_t(s.count) * (stats_.awake_vertices - awake_before);
  judge(bi, s.finite);
  log_changes(bi);
  strokes.end_tick(b, tick_);
}

// The broadphase, which also tells whether a stroke of the body opens or is released.
template <class S>
void World<S>::find_contacts(std::uint32_t bi) {
  Body<S>& b = bodies_[bi];
  const std::uint64_t c0 = stage_clock_ ? stage_clock_() : 0;
  recorders_[bi]->begin_broadphase(b);
  for (std::uint32_t t = 0; t < tool_slots_; ++t) stats_.candidate_blocks += find_candidates(b, t, tracks_[t]);
  recorders_[bi]->end_broadphase(b, tick_);
  if (stage_clock_) collision_ns_ += stage_clock_() - c0;
}

// The awake list, and the kernels' arguments for this tick's substeps.
template <class S>
Substep<S> World<S>::begin_tick(std::uint32_t bi) {
  Body<S>& b = bodies_[bi];
  b.awake_count = 0;
  for (std::uint32_t blk = 0; blk < b.blocks; ++blk) {
    BlockState<S>& s = b.block[blk];
    if (!s.awake) continue;
    will_change(b, blk);  // every awake block steps: captured once, here
    b.awake_list[b.awake_count++] = blk;
    s.max_speed2_bits = 0;
    s.changed = true;
    s.dirty = true;
  }
  const int nsub = substeps(bi);
  const S dts = static_cast<S>(1.0 / settings_.rate_hz / nsub);
  const Material& m = b.material;
  kernel::ForceArgs<S> fa = b.network_args();
  fa.stiffness = static_cast<S>(m.stiffness);
  fa.damping = static_cast<S>(m.damping);
  fa.anchor = static_cast<S>(m.anchor);
  fa.anchor_damping = static_cast<S>(m.anchor_damping);
  fa.inv_mass = static_cast<S>(1.0 / m.mass);
  fa.inv_dt = S(1) / dts;
  for (int k = 0; k < 3; ++k) fa.gravity_force[k] = m.gravity ? static_cast<S>(m.mass * settings_.gravity[k]) : S(0);
  fa.ax = b.ax.data(), fa.ay = b.ay.data(), fa.az = b.az.data();  // the arrays path; the others use the scratch
  const kernel::IntegrateArgs<S> ia{b.x.data(),  b.y.data(),  b.z.data(),  b.wx.data(), b.wy.data(), b.wz.data(),
                                    b.ax.data(), b.ay.data(), b.az.data(), dts,         S(1) / dts};
  return Substep<S>{.body = b,
                    .forces = fa,
                    .integrate = ia,
                    .integrator = settings_.integrator,
                    .velocity = b.velocity,
                    .count = nsub,
                    .index = 0,
                    .dt = dts,
                    .grabs = grabs_,
                    .potential = potential_.data(),
                    .yield_masks = yield_masks_.data(),
                    .scratch = scratch_.data(),
                    .ring = ring_.data(),
                    .speed_limit2 = static_cast<S>(b.speed_limit * b.speed_limit)};
}

// The narrow phase of every tool not holding the body, and the tick average
// of the substeps' contact forces.
template <class S>
void World<S>::resolve_contacts(Body<S>& b, const Substep<S>& s) {
  const std::uint64_t n0 = stage_clock_ ? stage_clock_() : 0;
  const double alpha0 = double(s.index) / s.count, alpha1 = double(s.index + 1) / s.count;
  for (std::uint32_t t = 0; t < tool_slots_; ++t) {
    ToolContact<S>& tc = b.tools[t];
    if (tc.candidate_count == 0 || tc.grabbing) continue;
    const Vec3d before = tracks_[t].force;
    narrow_.resolve(b, t, tracks_[t], alpha0, alpha1, s.dt);
    for (int k = 0; k < 3; ++k) tracks_[t].force[k] = before[k] + (tracks_[t].force[k] - before[k]) / s.count;
  }
  if (stage_clock_) collision_ns_ += stage_clock_() - n0;
}

// The guard: a tick whose state went non-finite, too fast, or gained energy
// with nothing putting it in is undone, and the body steps finer from then on.
template <class S>
void World<S>::judge(std::uint32_t bi, bool finite) {
  Body<S>& b = bodies_[bi];
  double energy = 0;
  for (const BlockState<S>& s : b.block) energy += s.energy;
  const bool swapped = recorders_[bi]->take_exchange_input();  // energy a swap brought is input too
  bool input = b.external_input || swapped;
  b.external_input = false;
  for (std::uint32_t t = 0; t < tool_slots_; ++t)
    input = input || b.tools[t].grabbing || (tracks_[t].active && b.tools[t].candidate_count > 0);
  if (!std::isfinite(energy)) finite = false;
  const bool grew = !input && energy > kEnergyGrowth * b.energy_ref + b.energy_floor;
  if (finite && !grew) {
    b.energy = energy;
    if (input) b.energy_ref = std::max(b.energy_ref, energy);
    settle(b, energy);
    return;
  }
  ++b.blowups;
  ++blowups_total_;
  ++stats_.blowups;
  last_blowup_body_ = bi;
  last_blowup_cause_ = finite ? BlowupCause::energy_growth : BlowupCause::non_finite;
  b.boost = std::min(kMaxSubstepBoost, b.boost * 2);
  for (std::uint32_t t = 0; t < tool_slots_; ++t) {
    // Nothing from a diverged step reaches the haptics.
    if (b.tools[t].candidate_count > 0 || b.tools[t].grabbing) tracks_[t].force = {}, tracks_[t].contacts = 0;
  }
  restore_body(b);
  b.energy_ref = 0;
  for (const BlockState<S>& s : b.block) b.energy_ref += s.energy;
  b.energy = b.energy_ref;
}

// After a good tick: boxes grow with the motion, moving blocks wake their
// neighbours, quiet untouched ones sleep, and now and then the moving ones
// are saved as the last good state.
template <class S>
void World<S>::settle(Body<S>& b, double energy) {
  const double dt = 1.0 / settings_.rate_hz;
  const S sleep2 = static_cast<S>(settings_.sleep_speed * settings_.sleep_speed);
  for (std::uint32_t q = 0; q < b.awake_count; ++q) {
    const std::uint32_t blk = b.awake_list[q];
    BlockState<S>& s = b.block[blk];
    const S v2 = static_cast<S>(std::bit_cast<float>(s.max_speed2_bits));
    const bool moving = !(v2 < sleep2);
    s.grow += std::sqrt(v2) * static_cast<S>(dt);
    if (s.grow > S(0.5) * s.reach) refit_block(b, blk);
    if (moving) {
      s.quiet_ticks = 0;
      for (std::uint32_t e = b.block_neighbour_begin[blk]; e < b.block_neighbour_begin[blk + 1]; ++e)
        wake_block(b, b.block_neighbours[e]);
    } else if (!s.touched && ++s.quiet_ticks >= settings_.sleep_ticks) {
      sleep_block(b, blk);
    }
  }
  if (++b.checkpoint_age >= kCheckpointInterval && energy <= 2.0 * b.energy_ref + b.energy_floor) {
    b.checkpoint_age = 0;
    for (std::uint32_t blk = 0; blk < b.blocks; ++blk)
      if (b.block[blk].dirty && b.block[blk].awake) checkpoint_block(b, blk);
  }
  if (b.awake_blocks == 0) b.energy_ref = std::max(0.0, energy);
  update_box(b);
}

// The vertex ranges that moved this tick, for the viewers, merged where they meet.
template <class S>
void World<S>::log_changes(std::uint32_t bi) {
  Body<S>& b = bodies_[bi];
  recorders_[bi]->mark_exchanged(b);
  for (std::uint32_t blk = 0; blk < b.blocks; ++blk) {
    BlockState<S>& s = b.block[blk];
    if (s.changed) {
      if (change_count_ > 0 && changes_[change_count_ - 1].body == bi &&
          changes_[change_count_ - 1].end == b.begin_of(blk))
        changes_[change_count_ - 1].end = b.end_of(blk);
      else
        changes_[change_count_++] = {bi, b.begin_of(blk), b.end_of(blk)};
    }
    s.changed = false;
    s.touched = false;
  }
}

template <class S>
void World<S>::positions(std::size_t bi, std::span<Vec3f> out) const {
  const Body<S>& b = bodies_[bi];
  const std::size_t n = std::min<std::size_t>(out.size(), b.n);
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::uint32_t k = b.to_internal[i];
    out[i] = {static_cast<float>(b.x[k]), static_cast<float>(b.y[k]), static_cast<float>(b.z[k])};
  }
}

template <class S>
Vec3d World<S>::position(std::size_t bi, std::uint32_t original) const {
  const Body<S>& b = bodies_[bi];
  const std::uint32_t k = b.to_internal[original];
  return {double(b.x[k]), double(b.y[k]), double(b.z[k])};
}

template <class S>
void World<S>::set_state(std::size_t bi, std::uint32_t original, const Vec3d& p, const Vec3d& v) {
  Body<S>& b = bodies_[bi];
  if (original >= b.n) throw std::out_of_range("set_state: vertex " + std::to_string(original) + " does not exist");
  const std::uint32_t k = b.to_internal[original];
  const double dts = 1.0 / settings_.rate_hz / substeps(bi);
  will_change(b, k / kBlock);  // an open stroke holds scripted changes too
  for (std::uint32_t e = b.block_neighbour_begin[k / kBlock]; e < b.block_neighbour_begin[k / kBlock + 1]; ++e)
    will_change(b, b.block_neighbours[e]);
  b.x[k] = static_cast<S>(p[0]), b.y[k] = static_cast<S>(p[1]), b.z[k] = static_cast<S>(p[2]);
  b.wx[k] = static_cast<S>(stored_motion(b.velocity, v[0], dts));
  b.wy[k] = static_cast<S>(stored_motion(b.velocity, v[1], dts));
  b.wz[k] = static_cast<S>(stored_motion(b.velocity, v[2], dts));
  sync_records(b, k, static_cast<S>(1.0 / dts));
  const std::uint32_t blk = k / kBlock;
  wake_block(b, blk);
  b.block[blk].grow += static_cast<S>(norm({p[0] - b.rx[k], p[1] - b.ry[k], p[2] - b.rz[k]}));
  // Its block's and its spring neighbours' blocks' forces changed.
  b.block[blk].accel_current = false;
  for (std::uint32_t e = b.block_neighbour_begin[blk]; e < b.block_neighbour_begin[blk + 1]; ++e)
    b.block[b.block_neighbours[e]].accel_current = false;
  b.external_input = true;  // scripted energy is input, not a blow-up
  update_box(b);
}

template <class S>
void World<S>::wake_all(std::size_t bi) {
  Body<S>& b = bodies_[bi];
  for (std::uint32_t blk = 0; blk < b.blocks; ++blk) wake_block(b, blk);
}

template <class S>
std::uint64_t World<S>::hash() const {
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&h](const void* p, std::size_t n) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < n; ++i) h = (h ^ c[i]) * 1099511628211ull;
  };
  for (const Body<S>& b : bodies_)
    for (std::uint32_t i = 0; i < b.n; ++i) {
      const std::uint32_t k = b.to_internal[i];
      const S p[3] = {b.x[k], b.y[k], b.z[k]};
      mix(p, sizeof p);
    }
  return h;
}

template <class S>
std::size_t World<S>::bytes() const {
  std::size_t total = sizeof(*this) + changes_.capacity() * sizeof(ChangeRange) + potential_.capacity() * 8 +
                      scratch_.bytes() + ring_.bytes() + yield_masks_.capacity() + narrow_.bytes();
  for (const Body<S>& b : bodies_) total += b.bytes();
  for (const auto& e : recorders_) total += e->bytes();
  return total;
}

template class World<float>;
template class World<double>;

}  // namespace sculpt::sim
