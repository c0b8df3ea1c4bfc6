#include "sim/world.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "sim/geometry.hpp"
#include "sim/stability.hpp"

namespace sculpt::sim {

namespace {

using kernel::kBlock;
using geometry::V3;

constexpr int kSnapshotInterval = 32;    // ticks between good-state snapshots of moving blocks
constexpr int kMaxBoost = 64;            // substep multiplier cap after repeated blow-ups
constexpr double kEnergyGrowth = 4.0;    // energy may fluctuate (Verlet's measured energy wobbles) but not 4×
constexpr double kGrabReach = 1.25;      // a grab holds vertices within this many radii of the tool
constexpr int kMaxSweeps = 16;           // narrow-phase sub-sweeps per substep for fast tools

template <class S>
bool overlaps(const std::array<S, 3>& alo, const std::array<S, 3>& ahi, const std::array<S, 3>& blo,
              const std::array<S, 3>& bhi, S grow) {
  return alo[0] - grow <= bhi[0] && blo[0] <= ahi[0] + grow && alo[1] - grow <= bhi[1] && blo[1] <= ahi[1] + grow &&
         alo[2] - grow <= bhi[2] && blo[2] <= ahi[2] + grow;
}

bool finite3(const Vec3d& v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }
double norm(const Vec3d& v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

template <class S>
V3<S> lerp(const Vec3d& a, const Vec3d& b, double t) {
  return {static_cast<S>(a[0] + (b[0] - a[0]) * t), static_cast<S>(a[1] + (b[1] - a[1]) * t),
          static_cast<S>(a[2] + (b[2] - a[2]) * t)};
}

}  // namespace

template <class S>
World<S>::World(const SimSettings& settings, int tool_slots) : settings_(settings) {
  validate(settings_);
  if (tool_slots < 0 || tool_slots > 64) throw std::invalid_argument("simulation: tool slots must be in [0, 64]");
  tool_slots_ = static_cast<std::uint32_t>(tool_slots);
  tracks_.resize(tool_slots_);
  feedback_.resize(tool_slots_);
}

template <class S>
std::uint32_t World<S>::add_body(const TriangleMesh& mesh, const Material& material, const BodyOptions& options) {
  // The ring is for the AVX2 kernels (the compiler's clones of it ran at
  // 27-31 ns per vertex-step here against 17-21 for their gathers from the
  // arrays) and for the integrators that step in one pass (velocity Verlet
  // keeps a(t) in ax..az): decided here, once. Body::ring_blocks > 0 says yes.
  BodyOptions body_options = options;
  body_options.ring = options.ring && settings_.integrator != Integrator::velocity_verlet && kernel::avx2_paths_active();
  Body<S> b = make_body<S>(mesh, material, body_options, static_cast<int>(tool_slots_));
  const SubstepChoice choice = choose_substeps_for_degree(b.max_degree, material, settings_);
  const double g = material.gravity ? norm(settings_.gravity) : 0.0;
  const double m = material.mass;
  b.energy_floor = b.n * m * (0.5 * 0.05 * 0.05 + g * b.extent) +
                   b.springs * material.stiffness * (0.01 * b.mean_edge) * (0.01 * b.mean_edge) + 1e-12;
  // Nothing a hand does moves a vertex at ten times the fastest tool, and no
  // motion of the network itself beats its stiffest mode swinging across the
  // whole mesh (ω_max · extent: light vertices on stiff springs legitimately
  // move far faster than any tool). Anything faster is divergence.
  b.speed_limit = std::max(10.0 * settings_.max_tool_speed, std::sqrt(choice.bound.lambda_max_bound) * b.extent);
  // At rest pose with no gravity a mesh is in equilibrium: it starts asleep.
  std::uint32_t awake = 0;
  if (material.gravity && g > 0.0) {
    for (std::uint32_t blk = 0; blk < b.blocks; ++blk) b.block[blk].awake = true;
    awake = b.blocks;
  }
  update_box(b);
  // Velocity Verlet keeps a(t) across steps and clay on the unfused path yields
  // between every block's forces and any block's move: both need ax..az for
  // every vertex. The rest integrate each block as soon as no later block
  // reads it, from a pool slot.
  // Bodies that step through the ring need neither (the ring's grabbed blocks
  // take one slot).
  const bool ring = b.ring_blocks > 0;
  if (settings_.integrator == Integrator::velocity_verlet || b.plastic) {
    for (auto* buf : {&b.ax, &b.ay, &b.az}) buf->resize(b.n, S(0), &b.arena);
  } else if (ring) {
    if (acc_free_.empty()) {
      acc_pool_.resize(3 * std::size_t{kBlock});
      acc_free_.assign(1, 0);
      pending_.resize(1);
    }
  } else if (acc_free_.size() < b.pending_capacity) {
    acc_pool_.resize(3 * std::size_t{kBlock} * b.pending_capacity);
    acc_free_.resize(b.pending_capacity);
    std::iota(acc_free_.begin(), acc_free_.end(), 0u);  // every slot free: each pass returns all it takes
    pending_.resize(b.pending_capacity);
  }
  b.arena.trim();  // every array is in place
  const std::size_t total_blocks = changes_.size() + b.blocks;
  bodies_.push_back(std::move(b));
  base_substeps_.push_back(choice.substeps);
  awake_total_.push_back(awake);
  changes_.resize(total_blocks);
  // Scratch sized for the largest body so far (the step never allocates):
  // only the body just added can raise a size.
  const Body<S>& added = bodies_.back();
  pe_scratch_.resize(std::max<std::size_t>(pe_scratch_.size(), added.blocks));
  outcode_stamp_.resize(pe_scratch_.size());
  outcode_.resize(std::max<std::size_t>(outcode_.size(), added.n));
  if (ring && ring_.size() < 8 * std::size_t{added.ring_blocks} * kBlock)
    ring_.resize(8 * std::size_t{added.ring_blocks} * kBlock);  // every body steps through it in turn
  // Clay: one yield mask per awake block (the fused pass marks them all before any is applied).
  if (added.plastic)
    yield_masks_.resize(std::max(yield_masks_.size(), yield_mask_bytes(added) * added.blocks));
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
  const double dt = 1.0 / settings_.rate_hz;
  for (std::uint32_t t = 0; t < tool_slots_; ++t) {
    ToolTrack& tr = tracks_[t];
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

  // More tools than slots: the extra ones are ignored, and counted.
  if (tools.size() > tool_slots_) stats_.ignored_tools += static_cast<std::uint32_t>(tools.size() - tool_slots_);

  for (std::uint32_t bi = 0; bi < bodies_.size(); ++bi) step_body(bi);

  for (std::uint32_t t = 0; t < tool_slots_; ++t) {
    ToolTrack& tr = tracks_[t];
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
void World<S>::wake(Body<S>& b, std::uint32_t blk) {
  BlockState<S>& s = b.block[blk];
  s.quiet_ticks = 0;
  if (!s.awake) {
    s.awake = true;
    ++awake_total_[&b - bodies_.data()];
  }
}

template <class S>
void World<S>::refit(Body<S>& b, std::uint32_t blk) {
  BlockState<S>& s = b.block[blk];
  const std::uint32_t b0 = b.begin_of(blk), b1 = b.end_of(blk);
  std::array<S, 3> lo{b.x[b0], b.y[b0], b.z[b0]}, hi = lo;
  for (std::uint32_t i = b0 + 1; i < b1; ++i) {
    lo[0] = std::min(lo[0], b.x[i]), hi[0] = std::max(hi[0], b.x[i]);
    lo[1] = std::min(lo[1], b.y[i]), hi[1] = std::max(hi[1], b.y[i]);
    lo[2] = std::min(lo[2], b.z[i]), hi[2] = std::max(hi[2], b.z[i]);
  }
  s.lo = lo;
  s.hi = hi;
  s.grow = 0;
}

template <class S>
void World<S>::update_box(Body<S>& b) {
  if (b.blocks == 0) return;
  for (int k = 0; k < 3; ++k) {
    b.lo[k] = std::numeric_limits<S>::max();
    b.hi[k] = std::numeric_limits<S>::lowest();
  }
  for (const BlockState<S>& s : b.block) {
    const S g = s.grow + s.reach;
    for (int k = 0; k < 3; ++k) {
      b.lo[k] = std::min(b.lo[k], s.lo[k] - g);
      b.hi[k] = std::max(b.hi[k], s.hi[k] + g);
    }
  }
}

template <class S>
void World<S>::broadphase(Body<S>& b, std::uint32_t t) {
  ToolTrack& tr = tracks_[t];
  ToolContact<S>& tc = b.tools[t];
  tc.candidate_count = 0;
  if (!tr.active || !tr.grab) {
    tc.grabbing = false;
    tc.grab_count = 0;
  }
  if (!tr.active) return;
  if (!overlaps(b.lo, b.hi, tr.lo, tr.hi, S(0))) {
    if (tc.grabbing) {  // still holding vertices though out of reach of the box: keep them awake
      for (std::uint32_t g = 0; g < tc.grab_count; ++g) {
        wake(b, tc.grabs[g].i / kBlock);
        b.block[tc.grabs[g].i / kBlock].touched = true;
      }
    }
    return;
  }
  for (std::uint32_t blk = 0; blk < b.blocks; ++blk) {
    BlockState<S>& s = b.block[blk];
    if (!overlaps(s.lo, s.hi, tr.lo, tr.hi, s.grow + s.reach)) continue;
    if (s.grow > S(0)) {
      refit(b, blk);
      if (!overlaps(s.lo, s.hi, tr.lo, tr.hi, s.reach)) continue;
    }
    tc.candidates[tc.candidate_count++] = blk;
    s.touched = true;
    wake(b, blk);
  }
  stats_.candidate_blocks += tc.candidate_count;

  if (tr.grab && !tr.grab_prev && !tc.grabbing) {
    tc.grabbing = true;
    tc.grab_count = 0;
    // Offsets from the pose at the start of the tick, where the grab forces start too.
    const V3<S> c = lerp<S>(tr.c0, tr.c1, 0.0), h = lerp<S>(tr.a0, tr.a1, 0.0);
    const V3<S> p0 = geometry::sub(c, h), p1 = geometry::add(c, h);
    const S reach = static_cast<S>(kGrabReach) * tr.radius;
    for (std::uint32_t k = 0; k < tc.candidate_count; ++k) {
      const std::uint32_t blk = tc.candidates[k];
      for (std::uint32_t i = b.begin_of(blk); i < b.end_of(blk) && tc.grab_count < tc.grabs.size(); ++i) {
        const V3<S> p{b.x[i], b.y[i], b.z[i]};
        const V3<S> d = geometry::sub(p, geometry::closest_on_segment(p, p0, p1));
        if (geometry::dot(d, d) <= reach * reach)
          tc.grabs[tc.grab_count++] = {i, p[0] - c[0], p[1] - c[1], p[2] - c[2]};
      }
    }
  }
  if (tc.grabbing)
    for (std::uint32_t g = 0; g < tc.grab_count; ++g) {
      wake(b, tc.grabs[g].i / kBlock);
      b.block[tc.grabs[g].i / kBlock].touched = true;
    }
}

// Keep the packed mirror of one vertex current (same formula as kernel::pack).
template <class S>
void World<S>::pack_vertex(Body<S>& b, std::uint32_t i, S inv_dt) {
  if (b.packed[0].empty()) return;
  for (auto& buf : b.packed) {  // both: a sleeping or just-pushed vertex must read the same from either
    S* q = buf.data() + 8 * static_cast<std::size_t>(i);
    if (b.material.model == ForceModel::linear) q[0] = b.x[i] - b.rx[i], q[1] = b.y[i] - b.ry[i], q[2] = b.z[i] - b.rz[i];
    else q[0] = b.x[i], q[1] = b.y[i], q[2] = b.z[i];
    q[3] = S(0);
    if (settings_.integrator == Integrator::position_verlet) {
      q[4] = b.wx[i] * inv_dt;
      q[5] = b.wy[i] * inv_dt;
      q[6] = b.wz[i] * inv_dt;
    } else {
      q[4] = b.wx[i], q[5] = b.wy[i], q[6] = b.wz[i];
    }
    q[7] = S(0);
  }
}

template <class S>
void World<S>::apply_pins(Body<S>& b, std::uint32_t blk, S inv_dt) {
  for (std::uint32_t p = b.pinned_begin[blk]; p < b.pinned_begin[blk + 1]; ++p) {
    const Pinned<S>& pin = b.pinned[p];
    b.x[pin.i] = pin.x, b.y[pin.i] = pin.y, b.z[pin.i] = pin.z;
    b.wx[pin.i] = b.wy[pin.i] = b.wz[pin.i] = S(0);  // no step, no velocity
    pack_vertex(b, pin.i, inv_dt);  // neighbours gathering from the packed buffer see the pin too
  }
}

template <class S>
void World<S>::push_vertex(Body<S>& b, std::uint32_t i, const std::array<S, 3>& delta,
                           const std::array<S, 3>& normal, S tool_normal_speed, S dts, ToolTrack& tr) {
  const std::uint32_t blk = i / kBlock;
  if (!b.block[blk].awake) wake(b, blk);
  b.block[blk].changed = true;
  b.block[blk].dirty = true;
  b.block[blk].grow += std::sqrt(geometry::dot(delta, delta));
  const bool verlet = settings_.integrator == Integrator::position_verlet;
  // Inelastic contact: keep the tangential velocity, and never let the normal
  // velocity be slower than the tool's (no bounce, no sticking inside).
  V3<S> v = verlet ? V3<S>{b.wx[i] / dts, b.wy[i] / dts, b.wz[i] / dts} : V3<S>{b.wx[i], b.wy[i], b.wz[i]};
  const S vn = geometry::dot(v, normal);
  if (vn < tool_normal_speed) v = geometry::add(v, geometry::mul(normal, tool_normal_speed - vn));
  b.x[i] += delta[0], b.y[i] += delta[1], b.z[i] += delta[2];
  if (verlet) {
    b.wx[i] = v[0] * dts, b.wy[i] = v[1] * dts, b.wz[i] = v[2] * dts;
  } else {
    b.wx[i] = v[0], b.wy[i] = v[1], b.wz[i] = v[2];
  }
  pack_vertex(b, i, S(1) / dts);
  // The force that produced this displacement in one substep, back on the tool.
  const double f = b.material.mass / (double(dts) * dts);
  tr.force[0] -= f * delta[0], tr.force[1] -= f * delta[1], tr.force[2] -= f * delta[2];
}

template <class S>
void World<S>::collide(Body<S>& b, std::uint32_t t, double alpha0, double alpha1, S dts) {
  ToolTrack& tr = tracks_[t];
  ToolContact<S>& tc = b.tools[t];
  const S r = tr.radius;
  const S r_out = r * S(1.0 + 1e-5);  // land just outside, so rounding never leaves a vertex inside
  const V3<S> c_start = lerp<S>(tr.c0, tr.c1, alpha0), c_end = lerp<S>(tr.c0, tr.c1, alpha1);
  const V3<S> motion = geometry::sub(c_end, c_start);
  const V3<S> tool_velocity = geometry::mul(motion, S(1) / dts);
  const S travel = std::sqrt(geometry::dot(motion, motion));
  const int sweeps = std::clamp(static_cast<int>(std::ceil(travel / (S(0.5) * r))), 1, kMaxSweeps);
  std::uint32_t pushes = 0;
  for (int k = 1; k <= sweeps; ++k) {
    const double ap = alpha0 + (alpha1 - alpha0) * (k - 1) / sweeps, a = alpha0 + (alpha1 - alpha0) * k / sweeps;
    const V3<S> c = lerp<S>(tr.c0, tr.c1, a), c_prev = lerp<S>(tr.c0, tr.c1, ap);
    const V3<S> h = lerp<S>(tr.a0, tr.a1, a);
    const V3<S> p0 = geometry::sub(c, h), p1 = geometry::add(c, h);
    const V3<S> step = geometry::sub(c, c_prev);
    const S step_len = std::sqrt(geometry::dot(step, step));

    // Cheap reject: a triangle's box misses the tool box of this sweep exactly
    // when its three vertices lie beyond the same face of that box, i.e. when
    // their outcodes (one bit per face) share a bit. Outcodes are computed a
    // block at a time and kept current through the pushes below.
    std::array<S, 3> core_lo, core_hi, box_lo, box_hi;
    for (int ax = 0; ax < 3; ++ax) {
      core_lo[ax] = std::min(p0[ax], p1[ax]), core_hi[ax] = std::max(p0[ax], p1[ax]);
      box_lo[ax] = core_lo[ax] - r - step_len, box_hi[ax] = core_hi[ax] + r + step_len;
    }
    const S far = (std::max(r, step_len) + r * S(1e-3)) * S(1.01);
    const S far2 = far * far;
    std::uint8_t* const oc = outcode_.data();
    if (++outcode_epoch_ == 0) {  // wrapped: forget every stamp
      std::fill(outcode_stamp_.begin(), outcode_stamp_.end(), 0u);
      outcode_epoch_ = 1;
    }
    auto code_block = [&](std::uint32_t blk) {
      kernel::outcodes(b.x.data(), b.y.data(), b.z.data(), b.begin_of(blk), b.end_of(blk), box_lo.data(),
                       box_hi.data(), oc);
      outcode_stamp_[blk] = outcode_epoch_;
    };
    // A triangle's vertices are its owner's block-mates or spring neighbours:
    // coding each candidate block and its neighbour blocks covers them all.
    auto code_once = [&](std::uint32_t blk) {
      if (outcode_stamp_[blk] != outcode_epoch_) code_block(blk);
    };
    for (std::uint32_t q = 0; q < tc.candidate_count; ++q) {
      const std::uint32_t blk = tc.candidates[q];
      code_once(blk);
      for (std::uint32_t e = b.block_neighbour_begin[blk]; e < b.block_neighbour_begin[blk + 1]; ++e)
        code_once(b.block_neighbours[e]);
    }

    // Triangles first: a tool smaller than a face touches no vertex, yet must not pass.
    for (std::uint32_t q = 0; q < tc.candidate_count; ++q) {
      const std::uint32_t blk = tc.candidates[q];
      b.for_each_triangle(blk, [&](const Triangle& tri) __attribute__((always_inline)) {
        if (oc[tri[0]] & oc[tri[1]] & oc[tri[2]]) return;
        const V3<S> A{b.x[tri[0]], b.y[tri[0]], b.z[tri[0]]};
        const V3<S> B{b.x[tri[1]], b.y[tri[1]], b.z[tri[1]]};
        const V3<S> C{b.x[tri[2]], b.y[tri[2]], b.z[tri[2]]};
        // Second reject, before the closest points: the gap between the
        // triangle's box and the core's box bounds their distance from below.
        // Only a triangle within r of the core, or crossed by it this sweep
        // (within step_len), is acted on; `far2` has a margin for rounding.
        S gap2 = 0;
        for (int ax = 0; ax < 3; ++ax) {
          const S g = std::max({std::min({A[ax], B[ax], C[ax]}) - core_hi[ax], core_lo[ax] - std::max({A[ax], B[ax], C[ax]}),
                                S(0)});
          gap2 += g * g;
        }
        if (gap2 > far2) return;
        V3<S> N = geometry::cross(geometry::sub(B, A), geometry::sub(C, A));
        const S area2 = std::sqrt(geometry::dot(N, N));
        if (!(area2 > S(0)) || !std::isfinite(area2)) return;
        N = geometry::mul(N, S(1) / area2);
        const V3<S> q_now = geometry::segment_point_nearest_triangle(p0, p1, A, B, C);
        V3<S> w{};
        const V3<S> t_near = geometry::closest_on_triangle(q_now, A, B, C, w);
        const V3<S> gap = geometry::sub(q_now, t_near);
        const S dist = std::sqrt(geometry::dot(gap, gap));
        const V3<S> q_prev = geometry::sub(q_now, step);
        const S h_now = geometry::dot(geometry::sub(q_now, A), N);
        const S h_prev = geometry::dot(geometry::sub(q_prev, A), N);
        // Did the tool core cross the face's plane inside the face during this sweep?
        const bool inside_face = w[0] > S(0) && w[1] > S(0) && w[2] > S(0);
        const bool crossed = inside_face && ((h_prev > 0) != (h_now > 0)) && h_prev != S(0);
        V3<S> dir;
        S depth;
        if (crossed || (inside_face && dist < r)) {
          const S side = crossed ? (h_prev > 0 ? S(1) : S(-1)) : (h_now >= 0 ? S(1) : S(-1));
          dir = geometry::mul(N, -side);  // the face moves away from the side the tool is on
          depth = r_out - side * h_now;
        } else if (dist < r && dist > S(0)) {
          dir = geometry::mul(gap, S(-1) / dist);
          depth = r_out - dist;
        } else {
          return;
        }
        if (!(depth > S(0))) return;
        const S ww = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
        const S tn = geometry::dot(tool_velocity, dir);
        for (int v = 0; v < 3; ++v) {
          if (!(w[v] > S(0))) continue;
          const S s = depth * w[v] / ww;
          push_vertex(b, tri[v], geometry::mul(dir, s), dir, tn, dts, tr);
          const std::uint32_t i = tri[v];  // its block was coded above
          oc[i] = kernel::outcode(b.x[i], b.y[i], b.z[i], box_lo.data(), box_hi.data());
        }
        ++pushes;
      });
    }

    // Then vertices: nothing ends inside the tool.
    for (std::uint32_t q = 0; q < tc.candidate_count; ++q) {
      const std::uint32_t blk = tc.candidates[q];
      for (std::uint32_t i = b.begin_of(blk); i < b.end_of(blk); ++i) {
        const V3<S> p{b.x[i], b.y[i], b.z[i]};
        const V3<S> core = geometry::closest_on_segment(p, p0, p1);
        const V3<S> d = geometry::sub(p, core);
        const S d2 = geometry::dot(d, d);
        if (!(d2 < r * r)) continue;
        const S dist = std::sqrt(d2);
        V3<S> n;
        if (dist > r * S(1e-6)) {
          n = geometry::mul(d, S(1) / dist);
        } else if (step_len > S(0)) {
          n = geometry::mul(step, S(1) / step_len);  // dead centre: carry it ahead of the tool
        } else {
          n = {0, 1, 0};
        }
        const V3<S> target = geometry::add(core, geometry::mul(n, r_out));
        push_vertex(b, i, geometry::sub(target, p), n, geometry::dot(tool_velocity, n), dts, tr);
        ++pushes;
      }
    }
  }
  tr.contacts = std::max(tr.contacts, pushes);
}

template <class S>
void World<S>::sleep(Body<S>& b, std::uint32_t blk) {
  BlockState<S>& s = b.block[blk];
  const std::uint32_t b0 = b.begin_of(blk), b1 = b.end_of(blk);
  for (std::uint32_t i = b0; i < b1; ++i) {
    b.wx[i] = b.wy[i] = b.wz[i] = S(0);
    if (!b.ax.empty()) b.ax[i] = b.ay[i] = b.az[i] = S(0);
    pack_vertex(b, i, S(1));  // at rest: velocity 0 whatever the dt
  }
  s.awake = false;
  s.accel_current = false;  // zeroed above
  s.quiet_ticks = 0;
  --awake_total_[&b - bodies_.data()];
  refit(b, blk);
  snapshot(b, blk);
}

template <class S>
void World<S>::snapshot(Body<S>& b, std::uint32_t blk) {
  const std::uint32_t b0 = b.begin_of(blk), b1 = b.end_of(blk);
  // Positions and clay rest shape from the same tick, or neither: a block
  // that is not finite keeps its older snapshot whole (and stays dirty).
  if (!b.save_positions(blk)) return;
  if (b.plastic) {
    std::copy(b.rx.data() + b0, b.rx.data() + b1, b.srx.data() + b0);
    std::copy(b.ry.data() + b0, b.ry.data() + b1, b.sry.data() + b0);
    std::copy(b.rz.data() + b0, b.rz.data() + b1, b.srz.data() + b0);
    if (!b.slen.empty())
      for (int s = 0; s < b.slots; ++s) {
        const std::size_t o = static_cast<std::size_t>(s) * b.n;
        std::copy(b.rest_length.data() + o + b0, b.rest_length.data() + o + b1, b.slen.data() + o + b0);
      }
  }
  b.block[blk].dirty = false;
}

template <class S>
void World<S>::restore(Body<S>& b) {
  for (std::uint32_t i = 0; i < b.n; ++i) {
    const std::array<S, 3> p = b.saved_position(i);
    b.x[i] = p[0], b.y[i] = p[1], b.z[i] = p[2];
    b.wx[i] = b.wy[i] = b.wz[i] = S(0);
    if (!b.ax.empty()) b.ax[i] = b.ay[i] = b.az[i] = S(0);
  }
  if (b.plastic) {
    std::copy_n(b.srx.data(), b.n, b.rx.data());
    std::copy_n(b.sry.data(), b.n, b.ry.data());
    std::copy_n(b.srz.data(), b.n, b.rz.data());
    if (!b.slen.empty()) std::copy_n(b.slen.data(), b.slen.size(), b.rest_length.data());
  }
  for (std::uint32_t i = 0; i < b.n; ++i) pack_vertex(b, i, S(1));  // velocity 0: any dt
  for (std::uint32_t blk = 0; blk < b.blocks; ++blk) {
    wake(b, blk);
    BlockState<S>& s = b.block[blk];
    s.changed = true;
    s.dirty = false;
    s.energy = 0;
    s.accel_current = false;  // zeroed above
    refit(b, blk);
  }
  for (auto& tc : b.tools) tc.grab_count = 0, tc.grabbing = false;
  update_box(b);
}

template <class S>
S World<S>::anchor_limit(const Body<S>& b) {
  // The anchor's rest position follows the vertex once it is more than
  // yield·(mean edge) away, so the anchor stops pulling the dent back out.
  return static_cast<S>(b.material.yield_strain) * b.mean_edge;
}

template <class S>
std::size_t World<S>::yield_mask_bytes(const Body<S>& b) {
  return (1 + static_cast<std::size_t>(b.slots)) * (kBlock / 8);
}

// Clay yield of one block on the present x (the unfused paths call it before
// integrating): a vectorised pass over squared lengths marks what might yield,
// and only those get the exact test (same bits as testing every entry).
template <class S>
void World<S>::plastic_flow(Body<S>& b, std::uint32_t blk, std::uint8_t* mask) {
  const bool springs = b.material.model == ForceModel::spring;
  kernel::ForceArgs<S> fa = b.network_args();
  // The current packed records match x, y, z here (the step and every push keep them so).
  if (!springs) fa.packed = nullptr;
  if (kernel::yield_candidates(fa, static_cast<S>(b.material.yield_strain), anchor_limit(b), springs, b.begin_of(blk),
                               b.end_of(blk), mask))
    plastic_apply(b, blk, mask, nullptr);
}

// The exact yield tests and clamps for the entries marked in mask, with the
// positions the step started from: x, or (spring model, fused pass, which has
// already moved x) the current packed records, which hold the same bits.
template <class S>
void World<S>::plastic_apply(Body<S>& b, std::uint32_t blk, const std::uint8_t* mask, const S* records) {
  const S y = static_cast<S>(b.material.yield_strain);
  const S limit = anchor_limit(b);
  const bool springs = b.material.model == ForceModel::spring;
  const std::uint32_t b0 = b.begin_of(blk);
  auto pos = [&](std::uint32_t i) -> std::array<S, 3> {
    if (records) return {records[8 * static_cast<std::size_t>(i)], records[8 * static_cast<std::size_t>(i) + 1],
                         records[8 * static_cast<std::size_t>(i) + 2]};
    return {b.x[i], b.y[i], b.z[i]};
  };
  constexpr std::uint32_t kRow = kBlock / 8;
  // Calls f(i) for every marked vertex of a row, in ascending order (bit k of
  // byte g is vertex 8g + k: 64 of them per little-endian word).
  auto each_marked = [&](const std::uint8_t* row, auto&& f) {
    for (std::uint32_t w = 0; w < kRow / 8; ++w) {
      std::uint64_t m;
      std::memcpy(&m, row + 8 * w, sizeof m);
      for (; m; m &= m - 1) f(b0 + 64 * w + static_cast<std::uint32_t>(std::countr_zero(m)));
    }
  };
  static_assert(std::endian::native == std::endian::little && kRow % 8 == 0);
  bool moved = false;
  each_marked(mask, [&](std::uint32_t i) {
    const std::array<S, 3> p = pos(i);
    const S ux = p[0] - b.rx[i], uy = p[1] - b.ry[i], uz = p[2] - b.rz[i];
    const S u = std::sqrt(ux * ux + uy * uy + uz * uz);
    if (u > limit) {
      const S keep = limit / u;  // fraction of the displacement that stays elastic
      b.rx[i] = p[0] - ux * keep, b.ry[i] = p[1] - uy * keep, b.rz[i] = p[2] - uz * keep;
      moved = true;
    }
  });
  if (moved) b.block[blk].dirty = true;
  if (!springs) return;
  // Springs: perfect plasticity, strain clamped to ±yield; both directed
  // copies of a spring get the same bits, wherever the other one lives.
  auto set_mirror = [&](std::uint32_t j, std::uint32_t i, S value) {
    for (int s = 0; s < b.slots; ++s) {
      const std::size_t e = static_cast<std::size_t>(s) * b.n + j;
      if (static_cast<std::int32_t>(j) + b.nbr[e] == static_cast<std::int32_t>(i) && j != i) {
        b.rest_length[e] = value;
        b.block[j / kBlock].dirty = true;
        return;
      }
    }
    for (std::uint32_t o = b.overflow_begin[j / kBlock]; o < b.overflow_begin[j / kBlock + 1]; ++o)
      if (b.overflow[o].i == j && b.overflow[o].j == static_cast<std::int32_t>(i)) b.overflow[o].rest_length = value;
  };
  auto yield_spring = [&](std::uint32_t i, std::int32_t j, S& rest) {
    if (static_cast<std::uint32_t>(j) == i) return;
    const std::array<S, 3> pi = pos(i), pj = pos(static_cast<std::uint32_t>(j));
    const S dx = pj[0] - pi[0], dy = pj[1] - pi[1], dz = pj[2] - pi[2];
    const S len = std::sqrt(dx * dx + dy * dy + dz * dz);
    S value = rest;
    if (len > rest * (S(1) + y)) value = len / (S(1) + y);
    else if (len < rest * (S(1) - y)) value = len / (S(1) - y);
    if (value != rest) {
      rest = value;
      set_mirror(static_cast<std::uint32_t>(j), i, value);
      b.block[i / kBlock].dirty = true;
    }
  };
  // An unmarked entry whose mirror yields earlier in this pass gets the value
  // the exact test would have left unchanged (same length, same clamp), so
  // skipping it is still exact.
  for (int s = 0; s < b.slots; ++s)
    each_marked(mask + kRow * (1 + s), [&](std::uint32_t i) {
      const std::size_t e = static_cast<std::size_t>(s) * b.n + i;
      yield_spring(i, static_cast<std::int32_t>(i) + b.nbr[e], b.rest_length[e]);
    });
  for (std::uint32_t o = b.overflow_begin[blk]; o < b.overflow_begin[blk + 1]; ++o)
    yield_spring(b.overflow[o].i, b.overflow[o].j, b.overflow[o].rest_length);
}

template <class S>
void World<S>::step_body(std::uint32_t bi) {
  Body<S>& b = bodies_[bi];
  const std::uint64_t c0 = stage_clock_ ? stage_clock_() : 0;
  for (std::uint32_t t = 0; t < tool_slots_; ++t) broadphase(b, t);
  if (stage_clock_) collision_ns_ += stage_clock_() - c0;
  if (awake_total_[bi] == 0) return;  // the whole mesh sleeps: it costs this much

  const int nsub = substeps(bi);
  const double dt = 1.0 / settings_.rate_hz;
  const S dts = static_cast<S>(dt / nsub);
  const Integrator integ = settings_.integrator;
  const Material& m = b.material;
  const bool verlet = integ == Integrator::position_verlet;

  b.awake_count = 0;
  for (std::uint32_t blk = 0; blk < b.blocks; ++blk) {
    BlockState<S>& s = b.block[blk];
    if (!s.awake) continue;
    b.awake_list[b.awake_count++] = blk;
    s.max_speed2_bits = 0;
    s.changed = true;
    s.dirty = true;
  }

  kernel::ForceArgs<S> fa = b.network_args();
  fa.stiffness = static_cast<S>(m.stiffness);
  fa.damping = static_cast<S>(m.damping);
  fa.anchor = static_cast<S>(m.anchor);
  fa.anchor_damping = static_cast<S>(m.anchor_damping);
  fa.inv_mass = static_cast<S>(1.0 / m.mass);
  fa.inv_dt = S(1) / dts;
  for (int k = 0; k < 3; ++k) fa.gravity_force[k] = m.gravity ? static_cast<S>(m.mass * settings_.gravity[k]) : S(0);
  fa.ax = b.ax.data(), fa.ay = b.ay.data(), fa.az = b.az.data();  // null without: a pool slot per block
  kernel::IntegrateArgs<S> ia{b.x.data(), b.y.data(), b.z.data(), b.wx.data(), b.wy.data(), b.wz.data(),
                              b.ax.data(), b.ay.data(), b.az.data(), dts, S(1) / dts};
  const bool whole_accel = !b.ax.empty();
  // The force and integrate passes of the block starting at b0 use pool slot k.
  auto use_slot = [&](std::uint32_t k, std::uint32_t b0) {
    S* a = acc_pool_.data() + 3 * std::size_t{kBlock} * k;
    fa.ax = a, fa.ay = a + kBlock, fa.az = a + 2 * kBlock;
    ia.ax = fa.ax, ia.ay = fa.ay, ia.az = fa.az;
    fa.acc_origin = ia.acc_origin = b0;
  };
  const kernel::Velocity vel = verlet ? kernel::Velocity::step : kernel::Velocity::stored;
  const S kg = static_cast<S>(m.grab_stiffness), inv_m = static_cast<S>(1.0 / m.mass);

  const S speed_limit2 = static_cast<S>(b.speed_limit * b.speed_limit);
  bool finite = true;
  bool grabbing = false;
  for (std::uint32_t t = 0; t < tool_slots_; ++t) grabbing = grabbing || b.tools[t].grabbing;
  // The fused single pass needs neighbours read from the packed buffer (AVX2
  // path) and forces before any kick (not velocity Verlet). Blocks holding
  // grabbed vertices step in pieces inside it (their grab springs go in
  // between forces and integration).
  // Clay yields on the state the tick starts from: the unfused paths test
  // before they integrate (velocity Verlet: before it drifts), the fused pass
  // marks while it computes the forces and applies after it; either way after
  // this tick's forces, which use the rest shape from before. (Linear-model
  // clay stays unfused: its packed records hold x − r, not x.)
  const bool clay = b.plastic;
  const bool fused = !b.packed[0].empty() && integ != Integrator::velocity_verlet && kernel::avx2_paths_active() &&
                     !(clay && m.model == ForceModel::linear);
  // Elastic float bodies without the double buffer (add_body decided) take
  // the same single pass through a ring of packed records instead: blocks are
  // packed into it, from the arrays that still hold the substep's start, just
  // before the first block that reads them steps (see
  // kernel::ForceArgs::ring_mask). Should the testing knob turn the AVX2
  // kernels off afterwards, the compiler's clones step the ring: the same bits.
  const bool ring = b.ring_blocks > 0;
  const std::size_t mask_bytes = yield_mask_bytes(b);
  auto mask_of = [&](std::uint32_t q) { return yield_masks_.data() + q * mask_bytes; };  // clay bodies only
  for (int sub = 0; sub < nsub; ++sub) {
    const double alpha0 = double(sub) / nsub, alpha1 = double(sub + 1) / nsub;
    const bool last = sub + 1 == nsub;
    if (integ == Integrator::velocity_verlet) {
      // The opening half kick uses a(t), which the last closing force pass
      // left in ax..az. A block that has not had one since it was created,
      // woken, restored or set by hand gets its forces first (before any
      // block drifts): otherwise its first step kicks with zero (or stale)
      // acceleration and the integrator starts first order.
      if (sub == 0 && clay)
        for (std::uint32_t q = 0; q < b.awake_count; ++q) plastic_flow(b, b.awake_list[q], mask_of(0));
      if (sub == 0)
        for (std::uint32_t q = 0; q < b.awake_count; ++q) {
          const std::uint32_t blk = b.awake_list[q];
          if (b.block[blk].accel_current) continue;
          kernel::forces(fa, m.model, vel, b.begin_of(blk), b.end_of(blk), b.overflow_begin[blk],
                         b.overflow_begin[blk + 1]);
        }
      for (std::uint32_t q = 0; q < b.awake_count; ++q) {
        const std::uint32_t blk = b.awake_list[q];
        b.block[blk].accel_current = true;  // the closing pass below recomputes them
        kernel::vv_open(ia, b.begin_of(blk), b.end_of(blk));
      }
    }
    auto account = [&](std::uint32_t q, const kernel::BlockSums<S>& sums) {
      BlockState<S>& s = b.block[b.awake_list[q]];
      S v2;
      std::memcpy(&v2, &sums.max_speed2_bits, sizeof(S));
      if (!std::isfinite(v2) || v2 > speed_limit2) finite = false;
      const auto key = std::bit_cast<std::uint32_t>(static_cast<float>(std::isfinite(v2) ? v2 : S(0)));
      s.max_speed2_bits = std::max(s.max_speed2_bits, key);
      if (last) s.energy = pe_scratch_[q] + 0.5 * m.mass * double(sums.sum_speed2);
    };
    // Grabbed vertices follow the tool through a spring each; the tool feels
    // the pull back. Reads x before any block of this substep integrates; each
    // grabbed block adds the accelerations (add_grabs) after its own forces,
    // from the same x (its block has not moved yet): the same bits, and no
    // per-grab buffer.
    auto grab_force = [&](const V3<S>& c, const Grab<S>& gr) {
      return V3<S>{kg * (c[0] + gr.ox - b.x[gr.i]), kg * (c[1] + gr.oy - b.y[gr.i]), kg * (c[2] + gr.oz - b.z[gr.i])};
    };
    auto grab_springs = [&] {
      for (std::uint32_t t = 0; t < tool_slots_; ++t) {
        ToolContact<S>& tc = b.tools[t];
        if (!tc.grabbing) continue;
        ToolTrack& tr = tracks_[t];
        const V3<S> c = lerp<S>(tr.c0, tr.c1, alpha0);
        for (std::uint32_t g = 0; g < tc.grab_count; ++g) {
          const V3<S> f = grab_force(c, tc.grabs[g]);
          tr.force[0] -= double(f[0]) / nsub, tr.force[1] -= double(f[1]) / nsub, tr.force[2] -= double(f[2]) / nsub;
        }
        tr.contacts = std::max(tr.contacts, tc.grab_count);
      }
    };
    auto add_grabs = [&](std::uint32_t blk) {  // into fa.ax.. (the block's accelerations), tool by tool
      const std::uint32_t b0 = b.begin_of(blk), b1 = b.end_of(blk);
      for (std::uint32_t t = 0; t < tool_slots_; ++t) {
        const ToolContact<S>& tc = b.tools[t];
        if (!tc.grabbing) continue;
        const V3<S> c = lerp<S>(tracks_[t].c0, tracks_[t].c1, alpha0);
        const Grab<S>* first = tc.grabs.data();
        const Grab<S>* g = std::lower_bound(first, first + tc.grab_count, b0,
                                            [](const Grab<S>& gr, std::uint32_t v) { return gr.i < v; });
        for (; g != first + tc.grab_count && g->i < b1; ++g) {
          const V3<S> f = grab_force(c, *g);
          const std::uint32_t k = g->i - fa.acc_origin;
          fa.ax[k] += f[0] * inv_m, fa.ay[k] += f[1] * inv_m, fa.az[k] += f[2] * inv_m;
        }
      }
    };
    auto mark_grabbed = [&](bool on) {
      for (std::uint32_t t = 0; t < tool_slots_; ++t)
        for (std::uint32_t g = 0; g < b.tools[t].grab_count; ++g) b.block[b.tools[t].grabs[g].i / kBlock].grabbed = on;
    };
    if (fused) {
      // One pass per block while its data is in L1: forces (neighbours from the
      // current packed buffer), integrate, then pack into the other buffer.
      if constexpr (std::is_same_v<S, float>) {
        fa.packed = b.packed[b.packed_cur].data();
        float* next = b.packed[b.packed_cur ^ 1].data();
        if (grabbing) {
          mark_grabbed(true);
          grab_springs();
        }
        const bool yields = clay && sub == 0;
        for (std::uint32_t q = 0; q < b.awake_count; ++q) {
          const std::uint32_t blk = b.awake_list[q], b0 = b.begin_of(blk), b1 = b.end_of(blk);
          if (!whole_accel) use_slot(0, b0);  // nothing waits here: later blocks read the other packed buffer
          if (b.block[blk].grabbed) {
            // A block holding grabbed vertices goes in pieces: its forces (its
            // own x and w are still the step's start, its neighbours come from
            // the current packed buffer), the grab springs, integrate, pack.
            // The same operations in the same order as the unfused path: the
            // same bits.
            pe_scratch_[q] = kernel::forces(fa, m.model, vel, b0, b1, b.overflow_begin[blk], b.overflow_begin[blk + 1]);
            if (yields)  // before it moves, as the fused blocks mark theirs
              kernel::yield_candidates(fa, static_cast<S>(m.yield_strain), anchor_limit(b),
                                       m.model == ForceModel::spring, b0, b1, mask_of(q));
            add_grabs(blk);
            account(q, kernel::integrate(ia, integ, b0, b1));
            kernel::pack(fa, m.model, vel, next, b0, b1);
            continue;
          }
          kernel::YieldArgs ya{};
          if (yields) ya = {mask_of(q), static_cast<float>(m.yield_strain), anchor_limit(b)};
          float potential = 0;
          const kernel::BlockSums<float> sums =
              kernel::step_block_fused(fa, ia, m.model, integ, b0, b1, b.overflow_begin[blk], b.overflow_begin[blk + 1],
                                       next, potential, yields ? &ya : nullptr);
          pe_scratch_[q] = potential;
          account(q, sums);
        }
        // The current buffer still holds every vertex as the step found it.
        if (yields)
          for (std::uint32_t q = 0; q < b.awake_count; ++q)
            plastic_apply(b, b.awake_list[q], mask_of(q), b.packed[b.packed_cur].data());
        if (grabbing) mark_grabbed(false);
        b.packed_cur ^= 1;
      }
    } else if (ring) {
      if constexpr (std::is_same_v<S, float>) {
        const std::uint32_t mask = b.ring_blocks * kBlock - 1;
        fa.packed = ring_.data();
        fa.ring_mask = mask;
        fa.ring_stamp = b.ring_stamp.data();
        fa.ring_epoch = ++b.ring_epoch;
        fa.far_records = b.far_records.data();
        // Block c into the ring (and its far vertices' records aside) once
        // per substep, before anything moves it: every block within
        // kRingReach of the stepping one holds its ring place until the
        // stepping reaches kRingReach past it, as the awake list ascends.
        auto into_ring = [&](std::uint32_t c) {
          if (b.ring_stamp[c] == fa.ring_epoch) return;
          b.ring_stamp[c] = fa.ring_epoch;
          const std::uint32_t c0 = b.begin_of(c);
          float* records = ring_.data() + 8 * std::size_t{c0 & mask};
          kernel::pack_into(fa, m.model, vel, records, c0, b.end_of(c));
          for (std::uint32_t k = b.far_vertex_begin[c]; k < b.far_vertex_begin[c + 1]; ++k)
            std::memcpy(b.far_records.data() + 8 * std::size_t{k}, records + 8 * std::size_t{b.far_vertices[k] - c0},
                        8 * sizeof(float));
        };
        if (grabbing) {
          mark_grabbed(true);
          grab_springs();
        }
        for (std::uint32_t q = 0; q < b.awake_count; ++q) {
          const std::uint32_t blk = b.awake_list[q], b0 = b.begin_of(blk), b1 = b.end_of(blk);
          into_ring(blk);
          for (std::uint32_t e = b.block_neighbour_begin[blk]; e < b.block_neighbour_begin[blk + 1]; ++e) {
            const std::uint32_t c = b.block_neighbours[e];
            if (c + kernel::kRingReach >= blk && c <= blk + kernel::kRingReach) into_ring(c);
          }
          use_slot(0, b0);  // for the pieces (grabbed blocks, the portable clones)
          if (b.block[blk].grabbed) {  // in pieces, as on the fused path: the grab springs go in between
            pe_scratch_[q] = kernel::forces(fa, m.model, vel, b0, b1, b.overflow_begin[blk], b.overflow_begin[blk + 1]);
            add_grabs(blk);
            account(q, kernel::integrate(ia, integ, b0, b1));
            continue;
          }
          float potential = 0;
          const kernel::BlockSums<float> sums = kernel::step_block_fused(
              fa, ia, m.model, integ, b0, b1, b.overflow_begin[blk], b.overflow_begin[blk + 1], nullptr, potential);
          pe_scratch_[q] = potential;  // before account(), which adds it to the block's energy
          account(q, sums);
        }
        if (grabbing) mark_grabbed(false);
      }
    } else {
      if constexpr (std::is_same_v<S, float>) {
        if (fa.packed)
          for (std::uint32_t q = 0; q < b.awake_count; ++q)
            kernel::pack(fa, m.model, vel, b.packed[b.packed_cur].data(), b.begin_of(b.awake_list[q]),
                         b.end_of(b.awake_list[q]));
      }
      if (grabbing) {
        mark_grabbed(true);
        grab_springs();
      }
      if (whole_accel) {
        for (std::uint32_t q = 0; q < b.awake_count; ++q) {
          const std::uint32_t blk = b.awake_list[q];
          pe_scratch_[q] = kernel::forces(fa, m.model, vel, b.begin_of(blk), b.end_of(blk), b.overflow_begin[blk],
                                          b.overflow_begin[blk + 1]);
        }
        if (clay && sub == 0 && integ != Integrator::velocity_verlet)  // nothing has moved yet (Verlet: done above)
          for (std::uint32_t q = 0; q < b.awake_count; ++q) plastic_flow(b, b.awake_list[q], mask_of(0));
        for (std::uint32_t q = 0; q < b.awake_count; ++q) {
          const std::uint32_t blk = b.awake_list[q];
          if (b.block[blk].grabbed) add_grabs(blk);
          account(q, kernel::integrate(ia, integ, b.begin_of(blk), b.end_of(blk)));
        }
      } else {
        // Jacobi in place: a block integrates once every block that reads it
        // (last_reader) has its forces, so nothing reads a moved neighbour,
        // and its accelerations wait in a pool slot meanwhile: a handful of
        // blocks, not ax..az for every vertex. The same operations on the same
        // inputs as forces-then-integrate over the whole body: the same bits.
        auto free_slots = static_cast<std::uint32_t>(acc_free_.size());  // all of them, in any order
        std::uint32_t waiting = 0;
        auto integrate_waiting = [&](const Pending& p) {
          const std::uint32_t blk = b.awake_list[p.q];
          use_slot(p.slot, b.begin_of(blk));
          if (b.block[blk].grabbed) add_grabs(blk);
          account(p.q, kernel::integrate(ia, integ, b.begin_of(blk), b.end_of(blk)));
          acc_free_[free_slots++] = p.slot;
        };
        for (std::uint32_t q = 0; q < b.awake_count; ++q) {
          const std::uint32_t blk = b.awake_list[q];
          const std::uint32_t slot = acc_free_[--free_slots];  // ≥ pending_capacity slots: never runs out
          use_slot(slot, b.begin_of(blk));
          pe_scratch_[q] = kernel::forces(fa, m.model, vel, b.begin_of(blk), b.end_of(blk), b.overflow_begin[blk],
                                          b.overflow_begin[blk + 1]);
          pending_[waiting++] = {q, slot};
          // Blocks between this one and the next awake one sleep: they read nothing.
          const std::uint32_t next_reader = q + 1 < b.awake_count ? b.awake_list[q + 1] : b.blocks;
          for (std::uint32_t p = 0; p < waiting;) {
            if (b.last_reader[b.awake_list[pending_[p].q]] < next_reader) {
              integrate_waiting(pending_[p]);
              pending_[p] = pending_[--waiting];
            } else {
              ++p;
            }
          }
        }
      }
      if (grabbing) mark_grabbed(false);
    }
    const std::uint64_t n0 = stage_clock_ ? stage_clock_() : 0;
    for (std::uint32_t t = 0; t < tool_slots_; ++t) {
      ToolContact<S>& tc = b.tools[t];
      if (tc.candidate_count == 0 || tc.grabbing) continue;
      const Vec3d before = tracks_[t].force;
      collide(b, t, alpha0, alpha1, dts);
      for (int k = 0; k < 3; ++k)  // tick average of the substeps' contact forces
        tracks_[t].force[k] = before[k] + (tracks_[t].force[k] - before[k]) / nsub;
    }
    if (stage_clock_) collision_ns_ += stage_clock_() - n0;
    if (!b.pinned.empty())
      for (std::uint32_t q = 0; q < b.awake_count; ++q) apply_pins(b, b.awake_list[q], S(1) / dts);
  }
  if constexpr (std::is_same_v<S, float>) {
    // Leave the packed buffer matching x and w, as the next fused tick expects.
    if (!fused && !b.packed[0].empty())
      for (std::uint32_t q = 0; q < b.awake_count; ++q)
        kernel::pack(fa, m.model, vel, b.packed[b.packed_cur].data(), b.begin_of(b.awake_list[q]), b.end_of(b.awake_list[q]));
  }
  for (std::uint32_t q = 0; q < b.awake_count; ++q) {
    const std::uint32_t blk = b.awake_list[q];
    stats_.awake_vertices += b.end_of(blk) - b.begin_of(blk);
  }
  stats_.awake_blocks += b.awake_count;

  // --- guard --------------------------------------------------------------------
  double energy = 0;
  for (const BlockState<S>& s : b.block) energy += s.energy;
  bool input = b.external_input;
  b.external_input = false;
  for (std::uint32_t t = 0; t < tool_slots_; ++t)
    input = input || b.tools[t].grabbing || (tracks_[t].active && b.tools[t].candidate_count > 0);
  if (!std::isfinite(energy)) finite = false;
  const bool grew = !input && energy > kEnergyGrowth * b.energy_ref + b.energy_floor;
  if (!finite || grew) {
    ++b.blowups;
    ++blowups_total_;
    ++stats_.blowups;
    last_blowup_body_ = bi;
    last_blowup_cause_ = finite ? BlowupCause::energy_growth : BlowupCause::non_finite;
    b.boost = std::min(kMaxBoost, b.boost * 2);
    for (std::uint32_t t = 0; t < tool_slots_; ++t) {
      // Nothing from a diverged step reaches the haptics.
      if (b.tools[t].candidate_count > 0 || b.tools[t].grabbing) tracks_[t].force = {}, tracks_[t].contacts = 0;
    }
    restore(b);
    b.energy_ref = 0;
    for (const BlockState<S>& s : b.block) b.energy_ref += s.energy;
    b.energy = b.energy_ref;
  } else {
    b.energy = energy;
    if (input) b.energy_ref = std::max(b.energy_ref, energy);

    const S sleep2 = static_cast<S>(settings_.sleep_speed * settings_.sleep_speed);
    for (std::uint32_t q = 0; q < b.awake_count; ++q) {
      const std::uint32_t blk = b.awake_list[q];
      BlockState<S>& s = b.block[blk];
      const S v2 = static_cast<S>(std::bit_cast<float>(s.max_speed2_bits));
      const bool moving = !(v2 < sleep2);
      s.grow += std::sqrt(v2) * static_cast<S>(dt);
      if (s.grow > S(0.5) * s.reach) refit(b, blk);
      if (moving) {
        s.quiet_ticks = 0;
        for (std::uint32_t e = b.block_neighbour_begin[blk]; e < b.block_neighbour_begin[blk + 1]; ++e)
          wake(b, b.block_neighbours[e]);
      } else if (!s.touched && ++s.quiet_ticks >= settings_.sleep_ticks) {
        sleep(b, blk);
      }
    }
    if (++b.snapshot_age >= kSnapshotInterval && energy <= 2.0 * b.energy_ref + b.energy_floor) {
      b.snapshot_age = 0;
      for (std::uint32_t blk = 0; blk < b.blocks; ++blk)
        if (b.block[blk].dirty && b.block[blk].awake) snapshot(b, blk);
    }
    if (awake_total_[bi] == 0) b.energy_ref = std::max(0.0, energy);
    update_box(b);
  }

  // --- change log -----------------------------------------------------------------
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
  for (std::uint32_t q = 0; q < b.awake_count; ++q)
    stats_.vertex_steps += std::uint64_t(nsub) * (b.end_of(b.awake_list[q]) - b.begin_of(b.awake_list[q]));
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
  b.x[k] = static_cast<S>(p[0]), b.y[k] = static_cast<S>(p[1]), b.z[k] = static_cast<S>(p[2]);
  if (settings_.integrator == Integrator::position_verlet) {
    b.wx[k] = static_cast<S>(v[0] * dts);
    b.wy[k] = static_cast<S>(v[1] * dts);
    b.wz[k] = static_cast<S>(v[2] * dts);
  } else {
    b.wx[k] = static_cast<S>(v[0]), b.wy[k] = static_cast<S>(v[1]), b.wz[k] = static_cast<S>(v[2]);
  }
  pack_vertex(b, k, static_cast<S>(1.0 / dts));
  const std::uint32_t blk = k / kBlock;
  wake(b, blk);
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
  for (std::uint32_t blk = 0; blk < b.blocks; ++blk) wake(b, blk);
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
  std::size_t total = sizeof(*this) + changes_.capacity() * sizeof(ChangeRange) + pe_scratch_.capacity() * 8 +
                      acc_pool_.bytes() + ring_.bytes() + acc_free_.capacity() * 4 + pending_.capacity() * sizeof(Pending) +
                      yield_masks_.capacity() + outcode_.capacity() + outcode_stamp_.capacity() * sizeof(std::uint32_t);
  for (const Body<S>& b : bodies_) total += b.bytes();
  return total;
}

template class World<float>;
template class World<double>;

}  // namespace sculpt::sim
