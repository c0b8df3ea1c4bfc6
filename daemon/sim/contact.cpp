#include "sim/contact.hpp"

#include <algorithm>
#include <cmath>

#include "sim/blocks.hpp"
#include "sim/kernels.hpp"
#include "sim/motion.hpp"

namespace sculpt::sim {

namespace {

using geometry::V3;
using kernel::kBlock;

constexpr double kGrabReach = 1.25;  // a grab holds vertices within this many radii of the tool
constexpr int kMaxSweeps = 16;       // narrow-phase sub-sweeps per substep for fast tools

template <class S>
bool overlaps(const std::array<S, 3>& alo, const std::array<S, 3>& ahi, const std::array<S, 3>& blo,
              const std::array<S, 3>& bhi, S grow) {
  return alo[0] - grow <= bhi[0] && blo[0] <= ahi[0] + grow && alo[1] - grow <= bhi[1] && blo[1] <= ahi[1] + grow &&
         alo[2] - grow <= bhi[2] && blo[2] <= ahi[2] + grow;
}

// Keep the blocks a grab holds awake and touched (they take part in the step).
template <class S>
void hold_grabbed(Body<S>& b, const ToolContact<S>& tc) {
  for (std::uint32_t g = 0; g < tc.grab_count; ++g) {
    will_change(b, tc.grabs[g].i / kBlock);
    wake_block(b, tc.grabs[g].i / kBlock);
    b.block[tc.grabs[g].i / kBlock].touched = true;
  }
}

// A grab pressed this tick takes the vertices within reach, with their
// offsets from the pose at the start of the tick, where the grab forces start too.
template <class S>
void take_hold(Body<S>& b, ToolContact<S>& tc, const ToolTrack<S>& tr) {
  tc.grabbing = true;
  tc.grab_count = 0;
  const V3<S> c = tr.centre(0.0), h = tr.half_axis(0.0);
  const V3<S> p0 = geometry::sub(c, h), p1 = geometry::add(c, h);
  const S reach = static_cast<S>(kGrabReach) * tr.radius;
  for (std::uint32_t k = 0; k < tc.candidate_count; ++k) {
    const std::uint32_t blk = tc.candidates[k];
    for (std::uint32_t i = b.begin_of(blk); i < b.end_of(blk) && tc.grab_count < tc.grabs.size(); ++i) {
      const V3<S> p{b.x[i], b.y[i], b.z[i]};
      const V3<S> d = geometry::sub(p, geometry::closest_on_segment(p, p0, p1));
      if (!(geometry::dot(d, d) <= reach * reach)) continue;
      Grab<S>& g = tc.grabs[tc.grab_count++];
      g.i = i, g.ox = p[0] - c[0], g.oy = p[1] - c[1], g.oz = p[2] - c[2];
    }
  }
}

}  // namespace

template <class S>
std::uint32_t find_candidates(Body<S>& b, std::uint32_t t, const ToolTrack<S>& tr) {
  ToolContact<S>& tc = b.tools[t];
  tc.candidate_count = 0;
  if (!tr.active || !tr.grab) {
    tc.grabbing = false;
    tc.grab_count = 0;
  }
  if (!tr.active) return 0;
  if (!overlaps(b.lo, b.hi, tr.lo, tr.hi, S(0))) {
    if (tc.grabbing) hold_grabbed(b, tc);  // out of reach of the box, still holding vertices
    return 0;
  }
  for (std::uint32_t blk = 0; blk < b.blocks; ++blk) {
    BlockState<S>& s = b.block[blk];
    if (!overlaps(s.lo, s.hi, tr.lo, tr.hi, s.grow + s.reach)) continue;
    if (s.grow > S(0)) {
      refit_block(b, blk);
      if (!overlaps(s.lo, s.hi, tr.lo, tr.hi, s.reach)) continue;
    }
    tc.candidates[tc.candidate_count++] = blk;
    will_change(b, blk);
    s.touched = true;
    wake_block(b, blk);
  }
  if (tr.grab && !tr.grab_prev && !tc.grabbing) take_hold(b, tc, tr);
  if (tc.grabbing) hold_grabbed(b, tc);
  return tc.candidate_count;
}

template <class S>
void push_vertex(Body<S>& b, std::uint32_t i, const std::array<S, 3>& delta, const std::array<S, 3>& normal,
                 S tool_normal_speed, S dts, ToolTrack<S>& tr) {
  const std::uint32_t blk = i / kBlock;
  will_change(b, blk);
  if (!b.block[blk].awake) wake_block(b, blk);
  b.block[blk].changed = true;
  b.block[blk].dirty = true;
  b.block[blk].grow += std::sqrt(geometry::dot(delta, delta));
  // Inelastic contact: keep the tangential velocity, and never let the normal
  // velocity be slower than the tool's (no bounce, no sticking inside).
  const kernel::Velocity kind = b.velocity;
  V3<S> v{velocity_of(kind, b.wx[i], dts), velocity_of(kind, b.wy[i], dts), velocity_of(kind, b.wz[i], dts)};
  const S vn = geometry::dot(v, normal);
  if (vn < tool_normal_speed) v = geometry::add(v, geometry::mul(normal, tool_normal_speed - vn));
  b.x[i] += delta[0], b.y[i] += delta[1], b.z[i] += delta[2];
  b.wx[i] = stored_motion(kind, v[0], dts), b.wy[i] = stored_motion(kind, v[1], dts);
  b.wz[i] = stored_motion(kind, v[2], dts);
  sync_records(b, i, S(1) / dts);
  // The force that produced this displacement in one substep, back on the tool.
  const double f = b.material.mass / (double(dts) * dts);
  tr.force[0] -= f * delta[0], tr.force[1] -= f * delta[1], tr.force[2] -= f * delta[2];
}

// One sweep of the tool: its core segment p0–p1 now, how far it moved since
// the last sweep, and the box any vertex it can act on lies in.
template <class S>
struct NarrowPhase<S>::Sweep {
  V3<S> p0, p1, step;
  S step_len, r, r_out;
  V3<S> tool_velocity;
  std::array<S, 3> core_lo, core_hi, box_lo, box_hi;
  S far2;  // squared distance past which a triangle's box is out of reach
  S dts;
};

template <class S>
void NarrowPhase<S>::reserve(std::uint32_t vertices, std::uint32_t blocks) {
  code_.resize(std::max<std::size_t>(code_.size(), vertices));
  stamp_.resize(std::max<std::size_t>(stamp_.size(), blocks));
}

template <class S>
void NarrowPhase<S>::resolve(Body<S>& b, std::uint32_t t, ToolTrack<S>& tr, double alpha0, double alpha1, S dts) {
  const ToolContact<S>& tc = b.tools[t];
  Sweep sw;
  sw.r = tr.radius;
  sw.r_out = sw.r * S(1.0 + 1e-5);  // land just outside, so rounding never leaves a vertex inside
  sw.dts = dts;
  const V3<S> motion = geometry::sub(tr.centre(alpha1), tr.centre(alpha0));
  sw.tool_velocity = geometry::mul(motion, S(1) / dts);
  const S travel = std::sqrt(geometry::dot(motion, motion));
  const int sweeps = std::clamp(static_cast<int>(std::ceil(travel / (S(0.5) * sw.r))), 1, kMaxSweeps);
  std::uint32_t pushes = 0;
  for (int k = 1; k <= sweeps; ++k) {
    const double ap = alpha0 + (alpha1 - alpha0) * (k - 1) / sweeps, a = alpha0 + (alpha1 - alpha0) * k / sweeps;
    const V3<S> c = tr.centre(a), c_prev = tr.centre(ap);
    const V3<S> h = tr.half_axis(a);
    sw.p0 = geometry::sub(c, h), sw.p1 = geometry::add(c, h);
    sw.step = geometry::sub(c, c_prev);
    sw.step_len = std::sqrt(geometry::dot(sw.step, sw.step));
    for (int ax = 0; ax < 3; ++ax) {
      sw.core_lo[ax] = std::min(sw.p0[ax], sw.p1[ax]), sw.core_hi[ax] = std::max(sw.p0[ax], sw.p1[ax]);
      sw.box_lo[ax] = sw.core_lo[ax] - sw.r - sw.step_len, sw.box_hi[ax] = sw.core_hi[ax] + sw.r + sw.step_len;
    }
    const S far = (std::max(sw.r, sw.step_len) + sw.r * S(1e-3)) * S(1.01);
    sw.far2 = far * far;
    code_candidates(b, tc, sw);
    // Triangles first: a tool smaller than a face touches no vertex, yet must not pass.
    pushes += push_triangles(b, tc, sw, tr);
    pushes += push_vertices(b, tc, sw, tr);  // then vertices: nothing ends inside the tool
  }
  tr.contacts = std::max(tr.contacts, pushes);
}

// Cheap reject: a triangle's box misses the tool box of this sweep exactly
// when its three vertices lie beyond the same face of that box, i.e. when
// their outcodes (one bit per face) share a bit. Outcodes are computed a
// block at a time and kept current through the pushes. A triangle's vertices
// are its owner's block-mates or spring neighbours: coding each candidate
// block and its neighbour blocks covers them all.
template <class S>
void NarrowPhase<S>::code_candidates(const Body<S>& b, const ToolContact<S>& tc, const Sweep& sw) {
  if (++epoch_ == 0) {  // wrapped: forget every stamp
    std::fill(stamp_.begin(), stamp_.end(), 0u);
    epoch_ = 1;
  }
  auto code_once = [&](std::uint32_t blk) {
    if (stamp_[blk] == epoch_) return;
    kernel::outcodes(b.x.data(), b.y.data(), b.z.data(), b.begin_of(blk), b.end_of(blk), sw.box_lo.data(),
                     sw.box_hi.data(), code_.data());
    stamp_[blk] = epoch_;
  };
  for (std::uint32_t q = 0; q < tc.candidate_count; ++q) {
    const std::uint32_t blk = tc.candidates[q];
    code_once(blk);
    for (std::uint32_t e = b.block_neighbour_begin[blk]; e < b.block_neighbour_begin[blk + 1]; ++e)
      code_once(b.block_neighbours[e]);
  }
}

template <class S>
std::uint32_t NarrowPhase<S>::push_triangles(Body<S>& b, const ToolContact<S>& tc, const Sweep& sw,
                                             ToolTrack<S>& tr) {
  std::uint8_t* const oc = code_.data();
  std::uint32_t pushes = 0;
  for (std::uint32_t q = 0; q < tc.candidate_count; ++q) {
    b.for_each_triangle(tc.candidates[q], [&](const Triangle& tri) __attribute__((always_inline)) {
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
        const S g = std::max({std::min({A[ax], B[ax], C[ax]}) - sw.core_hi[ax],
                              sw.core_lo[ax] - std::max({A[ax], B[ax], C[ax]}), S(0)});
        gap2 += g * g;
      }
      if (gap2 > sw.far2) return;
      V3<S> N = geometry::cross(geometry::sub(B, A), geometry::sub(C, A));
      const S area2 = std::sqrt(geometry::dot(N, N));
      if (!(area2 > S(0)) || !std::isfinite(area2)) return;
      N = geometry::mul(N, S(1) / area2);
      const V3<S> q_now = geometry::segment_point_nearest_triangle(sw.p0, sw.p1, A, B, C);
      V3<S> w{};
      const V3<S> t_near = geometry::closest_on_triangle(q_now, A, B, C, w);
      const V3<S> gap = geometry::sub(q_now, t_near);
      const S dist = std::sqrt(geometry::dot(gap, gap));
      const V3<S> q_prev = geometry::sub(q_now, sw.step);
      const S h_now = geometry::dot(geometry::sub(q_now, A), N);
      const S h_prev = geometry::dot(geometry::sub(q_prev, A), N);
      // Did the tool core cross the face's plane inside the face during this sweep?
      const bool inside_face = w[0] > S(0) && w[1] > S(0) && w[2] > S(0);
      const bool crossed = inside_face && ((h_prev > 0) != (h_now > 0)) && h_prev != S(0);
      V3<S> dir;
      S depth;
      if (crossed || (inside_face && dist < sw.r)) {
        const S side = crossed ? (h_prev > 0 ? S(1) : S(-1)) : (h_now >= 0 ? S(1) : S(-1));
        dir = geometry::mul(N, -side);  // the face moves away from the side the tool is on
        depth = sw.r_out - side * h_now;
      } else if (dist < sw.r && dist > S(0)) {
        dir = geometry::mul(gap, S(-1) / dist);
        depth = sw.r_out - dist;
      } else {
        return;
      }
      if (!(depth > S(0))) return;
      const S ww = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
      const S tn = geometry::dot(sw.tool_velocity, dir);
      for (int v = 0; v < 3; ++v) {
        if (!(w[v] > S(0))) continue;
        const S s = depth * w[v] / ww;
        push_vertex(b, tri[v], geometry::mul(dir, s), dir, tn, sw.dts, tr);
        const std::uint32_t i = tri[v];  // its block was coded above
        oc[i] = kernel::outcode(b.x[i], b.y[i], b.z[i], sw.box_lo.data(), sw.box_hi.data());
      }
      ++pushes;
    });
  }
  return pushes;
}

template <class S>
std::uint32_t NarrowPhase<S>::push_vertices(Body<S>& b, const ToolContact<S>& tc, const Sweep& sw,
                                            ToolTrack<S>& tr) {
  std::uint32_t pushes = 0;
  for (std::uint32_t q = 0; q < tc.candidate_count; ++q) {
    const std::uint32_t blk = tc.candidates[q];
    for (std::uint32_t i = b.begin_of(blk); i < b.end_of(blk); ++i) {
      const V3<S> p{b.x[i], b.y[i], b.z[i]};
      const V3<S> core = geometry::closest_on_segment(p, sw.p0, sw.p1);
      const V3<S> d = geometry::sub(p, core);
      const S d2 = geometry::dot(d, d);
      if (!(d2 < sw.r * sw.r)) continue;
      const S dist = std::sqrt(d2);
      V3<S> n;
      if (dist > sw.r * S(1e-6)) {
        n = geometry::mul(d, S(1) / dist);
      } else if (sw.step_len > S(0)) {
        n = geometry::mul(sw.step, S(1) / sw.step_len);  // dead centre: carry it ahead of the tool
      } else {
        n = {0, 1, 0};
      }
      const V3<S> target = geometry::add(core, geometry::mul(n, sw.r_out));
      push_vertex(b, i, geometry::sub(target, p), n, geometry::dot(sw.tool_velocity, n), sw.dts, tr);
      ++pushes;
    }
  }
  return pushes;
}

template std::uint32_t find_candidates(Body<float>&, std::uint32_t, const ToolTrack<float>&);
template std::uint32_t find_candidates(Body<double>&, std::uint32_t, const ToolTrack<double>&);
template void push_vertex(Body<float>&, std::uint32_t, const std::array<float, 3>&, const std::array<float, 3>&, float,
                          float, ToolTrack<float>&);
template void push_vertex(Body<double>&, std::uint32_t, const std::array<double, 3>&, const std::array<double, 3>&,
                          double, double, ToolTrack<double>&);
template class NarrowPhase<float>;
template class NarrowPhase<double>;

}  // namespace sculpt::sim
