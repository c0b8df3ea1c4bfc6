#include "sim/kernels.hpp"

#include <immintrin.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstring>

#include "sim/kernel_testing.hpp"

// Build every hot kernel twice, for AVX2 and for plain x86-64, and pick at load
// time (ifunc). -ffp-contract=off (top-level meson.build) keeps the two clones
// from fusing multiply-adds differently. SCULPT_SIM_KERNEL_NS lets a test build
// a second, clone-free copy of this file to compare against.
//
// GCC only: clang 14 compiles an externally visible target_clones function as
// the AVX2 clone alone (no default clone, no resolver), so a CPU without AVX2
// (qemu's default model in the VM suite, older hosts) dies of SIGILL. Under
// clang the portable kernels are built once for plain x86-64; the hand-written
// AVX2 path below is still chosen at run time from __builtin_cpu_supports.
#if defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES) && !defined(__clang__)
#define SCULPT_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define SCULPT_CLONES
#endif

#ifndef SCULPT_SIM_KERNEL_NS
#define SCULPT_SIM_KERNEL_NS kernel
#endif

namespace sculpt::sim::SCULPT_SIM_KERNEL_NS {

using kernel::BlockSums;
using kernel::ForceArgs;
using kernel::IntegrateArgs;
using kernel::kBlock;
using kernel::Overflow;
using kernel::Velocity;

namespace {

template <class S>
struct Tiny;
// Keeps 1/len finite at len = 0; products are taken one factor of 1/len at a
// time so nothing overflows.
template <>
struct Tiny<float> {
  static constexpr float value = 1e-20f;
};
template <>
struct Tiny<double> {
  static constexpr double value = 1e-150;
};

template <class S>
using Bits = std::conditional_t<sizeof(S) == 4, std::uint32_t, std::uint64_t>;

// Deterministic sum: eight interleaved partial sums combined in a fixed tree.
// Lane-wise adds vectorise without reassociation, unlike a plain reduction.
template <class S>
[[gnu::always_inline]] inline S sum8(const S* e, std::uint32_t n) {
  S part[8] = {};
  std::uint32_t i = 0;
  for (; i + 8 <= n; i += 8)
    for (int l = 0; l < 8; ++l) part[l] += e[i + l];
  for (int l = 0; i < n; ++i, ++l) part[l] += e[i];
  return ((part[0] + part[1]) + (part[2] + part[3])) + ((part[4] + part[5]) + (part[6] + part[7]));
}

// One directed spring i→j: adds its force on i to f and its half energy to pe.
// Shared by the vectorised slot loop and the scalar overflow loop so both round alike.
template <class S, ForceModel M>
[[gnu::always_inline]] inline void pair_force(S dx, S dy, S dz, S dvx, S dvy, S dvz, S erx, S ery, S erz, S L, S k,
                                              S c, S quarter_k, S& fx, S& fy, S& fz, S& pe) {
  if constexpr (M == ForceModel::spring) {
    const S len = std::sqrt(dx * dx + dy * dy + dz * dz);
    // No comparison here: under -ftrapping-math a compare on a possible NaN
    // cannot be if-converted and the loop would not vectorise. len + tiny == len
    // for every length above ~1e-13 m (float); padding (len 0) gives 0 force.
    const S inv = S(1) / (len + Tiny<S>::value);
    const S stretch = len - L;
    const S s = k * stretch * inv + ((c * (dvx * dx + dvy * dy + dvz * dz)) * inv) * inv;
    fx += s * dx;
    fy += s * dy;
    fz += s * dz;
    pe += quarter_k * stretch * stretch;
  } else {
    // erx.. = rest offset r_j − r_i: the spring wants d back to it.
    const S ex = dx - erx, ey = dy - ery, ez = dz - erz;
    fx += k * ex + c * dvx;
    fy += k * ey + c * dvy;
    fz += k * ez + c * dvz;
    pe += quarter_k * (ex * ex + ey * ey + ez * ez);
  }
}

// The force pass on one block, in pieces, so the AVX2 path below can swap in
// its own neighbour loop and share everything else (same operations, same
// order, same bits).
template <class S>
struct BlockScratch {
  alignas(64) S fx[kBlock], fy[kBlock], fz[kBlock], pe[kBlock];
  alignas(64) S vx[kBlock], vy[kBlock], vz[kBlock];
};

// Anchor, anchor damper and gravity; the block's own velocities.
template <class S, Velocity V>
[[gnu::always_inline]] inline void init_block(const ForceArgs<S>& A, std::uint32_t begin, std::uint32_t cnt,
                                              BlockScratch<S>& w) {
  const S* __restrict X = A.x;
  const S* __restrict Y = A.y;
  const S* __restrict Z = A.z;
  const S* __restrict WX = A.wx;
  const S* __restrict WY = A.wy;
  const S* __restrict WZ = A.wz;
  const S* __restrict RX = A.rx;
  const S* __restrict RY = A.ry;
  const S* __restrict RZ = A.rz;
  const S inv_dt = A.inv_dt, ka = A.anchor, ca = A.anchor_damping, half_ka = S(0.5) * ka;
  const S gx = A.gravity_force[0], gy = A.gravity_force[1], gz = A.gravity_force[2];
  for (std::uint32_t i = 0; i < cnt; ++i) {
    const std::uint32_t v = begin + i;
    S ux, uy, uz;
    if constexpr (V == Velocity::step) {
      ux = WX[v] * inv_dt;
      uy = WY[v] * inv_dt;
      uz = WZ[v] * inv_dt;
    } else {
      ux = WX[v];
      uy = WY[v];
      uz = WZ[v];
    }
    w.vx[i] = ux;
    w.vy[i] = uy;
    w.vz[i] = uz;
    const S dx = RX[v] - X[v], dy = RY[v] - Y[v], dz = RZ[v] - Z[v];
    w.fx[i] = ka * dx - ca * ux + gx;
    w.fy[i] = ka * dy - ca * uy + gy;
    w.fz[i] = ka * dz - ca * uz + gz;
    // Gravity's potential relative to rest: −m g·(x − r) = m g·(r − x).
    w.pe[i] = half_ka * (dx * dx + dy * dy + dz * dz) + (gx * dx + gy * dy + gz * dz);
  }
}

// Ring: neighbours from the ring of packed records (a.ring_mask), which hold
// what the arrays would give (x or u = x − r, w·1/dt): the same bits.
template <class S, ForceModel M, Velocity V, bool Ring = false>
[[gnu::always_inline]] inline void slots_generic(const ForceArgs<S>& A, std::uint32_t begin, std::uint32_t cnt,
                                                 BlockScratch<S>& w) {
  const S* __restrict X = A.x;
  const S* __restrict Y = A.y;
  const S* __restrict Z = A.z;
  const S* __restrict WX = A.wx;
  const S* __restrict WY = A.wy;
  const S* __restrict WZ = A.wz;
  const S* __restrict RX = A.rx;
  const S* __restrict RY = A.ry;
  const S* __restrict RZ = A.rz;
  const S inv_dt = A.inv_dt, k = A.stiffness, c = A.damping, quarter_k = S(0.25) * k;
  for (int s = 0; s < A.slots; ++s) {
    const std::int16_t* __restrict nb = A.nbr + static_cast<std::size_t>(s) * A.stride + begin;
    const S* __restrict L = M == ForceModel::spring ? A.rest_length + static_cast<std::size_t>(s) * A.stride + begin
                                                    : nullptr;
    for (std::uint32_t i = 0; i < cnt; ++i) {
      const std::uint32_t v = begin + i;
      const std::int32_t j = static_cast<std::int32_t>(v) + nb[i];
      S xj, yj, zj, ujx, ujy, ujz;  // what the spring compares: p (linear: u = p − r) and the velocity
      if constexpr (Ring) {
        const S* q = A.packed + 8 * static_cast<std::size_t>(static_cast<std::uint32_t>(j) & A.ring_mask);
        xj = q[0], yj = q[1], zj = q[2], ujx = q[4], ujy = q[5], ujz = q[6];
      } else {
        // (p_j − p_i) − (r_j − r_i) written as u_j − u_i with u = p − r: what the
        // packed path reads, so both paths round alike.
        if constexpr (M == ForceModel::linear) xj = X[j] - RX[j], yj = Y[j] - RY[j], zj = Z[j] - RZ[j];
        else xj = X[j], yj = Y[j], zj = Z[j];
        if constexpr (V == Velocity::step) ujx = WX[j] * inv_dt, ujy = WY[j] * inv_dt, ujz = WZ[j] * inv_dt;
        else ujx = WX[j], ujy = WY[j], ujz = WZ[j];
      }
      S dx, dy, dz, len = 0;
      if constexpr (M == ForceModel::linear) {
        dx = xj - (X[v] - RX[v]), dy = yj - (Y[v] - RY[v]), dz = zj - (Z[v] - RZ[v]);
      } else {
        dx = xj - X[v], dy = yj - Y[v], dz = zj - Z[v];
        len = L[i];
      }
      pair_force<S, M>(dx, dy, dz, ujx - w.vx[i], ujy - w.vy[i], ujz - w.vz[i], 0, 0, 0, len, k, c, quarter_k, w.fx[i],
                       w.fy[i], w.fz[i], w.pe[i]);
    }
  }
}

// High-degree extras (scalar). FromPacked: neighbours from the packed buffer
// (the fused pass has already overwritten x and w of earlier blocks); with
// Ring, from the ring, or for a far spring from the far records once its end's
// block has been packed this substep (it may have moved since), else from the
// arrays (it has not).
template <class S, ForceModel M, Velocity V, bool FromPacked, bool Ring = false>
[[gnu::always_inline]] inline void overflow_block(const ForceArgs<S>& A, std::uint32_t begin, std::uint32_t ob,
                                                  std::uint32_t oe, BlockScratch<S>& w) {
  const S* __restrict X = A.x;
  const S* __restrict Y = A.y;
  const S* __restrict Z = A.z;
  const S* __restrict WX = A.wx;
  const S* __restrict WY = A.wy;
  const S* __restrict WZ = A.wz;
  const S* __restrict RX = A.rx;
  const S* __restrict RY = A.ry;
  const S* __restrict RZ = A.rz;
  const S inv_dt = A.inv_dt, k = A.stiffness, c = A.damping, quarter_k = S(0.25) * k;
  for (std::uint32_t o = ob; o < oe; ++o) {
    const Overflow<S>& e = A.overflow[o];
    const std::uint32_t v = e.i, i = v - begin;
    const std::int32_t j = e.j;
    S xj, yj, zj, ujx, ujy, ujz;
    const S* q = nullptr;  // j's record, if it comes from one
    if constexpr (FromPacked && Ring) {
      if (e.far == kNotFar) q = A.packed + 8 * static_cast<std::size_t>(static_cast<std::uint32_t>(j) & A.ring_mask);
      else if (e.far != kFarAhead && A.ring_stamp[static_cast<std::uint32_t>(j) / kBlock] == A.ring_epoch)
        q = A.far_records + 8 * static_cast<std::size_t>(e.far);
    } else if constexpr (FromPacked) {
      q = A.packed + 8 * static_cast<std::size_t>(j);
    }
    if (q) {
      xj = q[0], yj = q[1], zj = q[2], ujx = q[4], ujy = q[5], ujz = q[6];
    } else {
      xj = X[j], yj = Y[j], zj = Z[j];
      if constexpr (V == Velocity::step) {
        ujx = WX[j] * inv_dt;
        ujy = WY[j] * inv_dt;
        ujz = WZ[j] * inv_dt;
      } else {
        ujx = WX[j];
        ujy = WY[j];
        ujz = WZ[j];
      }
    }
    S dx, dy, dz;
    if constexpr (M == ForceModel::linear) {
      if (!q) xj = X[j] - RX[j], yj = Y[j] - RY[j], zj = Z[j] - RZ[j];  // records hold u already
      dx = xj - (X[v] - RX[v]), dy = yj - (Y[v] - RY[v]), dz = zj - (Z[v] - RZ[v]);
    } else {
      dx = xj - X[v], dy = yj - Y[v], dz = zj - Z[v];
    }
    pair_force<S, M>(dx, dy, dz, ujx - w.vx[i], ujy - w.vy[i], ujz - w.vz[i], 0, 0, 0, e.rest_length, k, c, quarter_k,
                     w.fx[i], w.fy[i], w.fz[i], w.pe[i]);
  }
}

// Accelerations out; returns the block's energy.
template <class S>
[[gnu::always_inline]] inline S write_acc(const ForceArgs<S>& A, std::uint32_t begin, std::uint32_t cnt,
                                          BlockScratch<S>& w) {
  const S inv_m = A.inv_mass;
  S* __restrict AX = A.ax + (begin - A.acc_origin);
  S* __restrict AY = A.ay + (begin - A.acc_origin);
  S* __restrict AZ = A.az + (begin - A.acc_origin);
  for (std::uint32_t i = 0; i < cnt; ++i) {
    AX[i] = w.fx[i] * inv_m;
    AY[i] = w.fy[i] * inv_m;
    AZ[i] = w.fz[i] * inv_m;
  }
  return sum8(w.pe, cnt);
}

template <class S, ForceModel M, Velocity V, bool Ring = false>
[[gnu::always_inline]] inline S forces_impl(const ForceArgs<S>& A, std::uint32_t begin, std::uint32_t end,
                                            std::uint32_t ob, std::uint32_t oe) {
  BlockScratch<S> w;
  const std::uint32_t cnt = end - begin;
  init_block<S, V>(A, begin, cnt, w);
  slots_generic<S, M, V, Ring>(A, begin, cnt, w);
  overflow_block<S, M, V, Ring, Ring>(A, begin, ob, oe, w);
  return write_acc<S>(A, begin, cnt, w);
}

template <class S>
[[gnu::always_inline]] inline S dispatch_forces(const ForceArgs<S>& a, ForceModel model, Velocity vel,
                                                std::uint32_t begin, std::uint32_t end, std::uint32_t ob,
                                                std::uint32_t oe) {
  if (a.ring_mask) {
    if (model == ForceModel::spring)
      return vel == Velocity::step ? forces_impl<S, ForceModel::spring, Velocity::step, true>(a, begin, end, ob, oe)
                                   : forces_impl<S, ForceModel::spring, Velocity::stored, true>(a, begin, end, ob, oe);
    return vel == Velocity::step ? forces_impl<S, ForceModel::linear, Velocity::step, true>(a, begin, end, ob, oe)
                                 : forces_impl<S, ForceModel::linear, Velocity::stored, true>(a, begin, end, ob, oe);
  }
  if (model == ForceModel::spring) {
    return vel == Velocity::step
               ? forces_impl<S, ForceModel::spring, Velocity::step>(a, begin, end, ob, oe)
               : forces_impl<S, ForceModel::spring, Velocity::stored>(a, begin, end, ob, oe);
  }
  return vel == Velocity::step
             ? forces_impl<S, ForceModel::linear, Velocity::step>(a, begin, end, ob, oe)
             : forces_impl<S, ForceModel::linear, Velocity::stored>(a, begin, end, ob, oe);
}

// Restrict-qualified parameters (not locals): GCC only trusts those enough to
// vectorise a loop that reads and writes six arrays.
template <class S, Integrator I>
[[gnu::always_inline]] inline void integrate_loop(S* __restrict X, S* __restrict Y, S* __restrict Z,
                                                  S* __restrict WX, S* __restrict WY, S* __restrict WZ,
                                                  const S* __restrict AX, const S* __restrict AY,
                                                  const S* __restrict AZ, S dt, S inv_dt, std::uint32_t cnt,
                                                  S* __restrict sp) {
  const S dt2 = dt * dt, half_dt = S(0.5) * dt;
  for (std::uint32_t i = 0; i < cnt; ++i) {
    S ux, uy, uz;
    if constexpr (I == Integrator::position_verlet) {
      // x' = 2x − x_prev + a dt² kept as its step d = x − x_prev: d' = d + a dt²,
      // x' = x + d'. Same recurrence, but the velocity is never a difference
      // of two nearby positions, so float keeps its digits (the lab measured
      // the x_prev form 7% off the error/cost front at the default tick).
      const S dx = WX[i] + AX[i] * dt2;
      const S dy = WY[i] + AY[i] * dt2;
      const S dz = WZ[i] + AZ[i] * dt2;
      WX[i] = dx;
      WY[i] = dy;
      WZ[i] = dz;
      X[i] = X[i] + dx;
      Y[i] = Y[i] + dy;
      Z[i] = Z[i] + dz;
      ux = dx * inv_dt;
      uy = dy * inv_dt;
      uz = dz * inv_dt;
    } else if constexpr (I == Integrator::symplectic_euler) {
      ux = WX[i] + AX[i] * dt;
      uy = WY[i] + AY[i] * dt;
      uz = WZ[i] + AZ[i] * dt;
      WX[i] = ux;
      WY[i] = uy;
      WZ[i] = uz;
      X[i] = X[i] + ux * dt;
      Y[i] = Y[i] + uy * dt;
      Z[i] = Z[i] + uz * dt;
    } else {  // velocity Verlet, closing half kick
      ux = WX[i] + AX[i] * half_dt;
      uy = WY[i] + AY[i] * half_dt;
      uz = WZ[i] + AZ[i] * half_dt;
      WX[i] = ux;
      WY[i] = uy;
      WZ[i] = uz;
    }
    sp[i] = ux * ux + uy * uy + uz * uz;
  }
}

template <class S, Integrator I>
[[gnu::always_inline]] inline BlockSums<S> integrate_impl(const IntegrateArgs<S>& A, std::uint32_t begin,
                                                          std::uint32_t end) {
  alignas(64) S sp[kBlock];
  alignas(64) Bits<S> bits[kBlock];
  const std::uint32_t cnt = end - begin;
  integrate_loop<S, I>(A.x + begin, A.y + begin, A.z + begin, A.wx + begin, A.wy + begin, A.wz + begin,
                       A.ax + (begin - A.acc_origin), A.ay + (begin - A.acc_origin), A.az + (begin - A.acc_origin),
                       A.dt, A.inv_dt, cnt, sp);
  std::memcpy(bits, sp, sizeof(S) * cnt);
  Bits<S> m = 0;
  for (std::uint32_t i = 0; i < cnt; ++i) m = bits[i] > m ? bits[i] : m;
  return {sum8(sp, cnt), m};
}

template <class S>
[[gnu::always_inline]] inline BlockSums<S> dispatch_integrate(const IntegrateArgs<S>& a, Integrator integrator,
                                                              std::uint32_t begin, std::uint32_t end) {
  switch (integrator) {
    case Integrator::symplectic_euler:
      return integrate_impl<S, Integrator::symplectic_euler>(a, begin, end);
    case Integrator::velocity_verlet:
      return integrate_impl<S, Integrator::velocity_verlet>(a, begin, end);
    case Integrator::position_verlet:
      break;
  }
  return integrate_impl<S, Integrator::position_verlet>(a, begin, end);
}

template <class S>
[[gnu::always_inline]] inline void vv_open_impl(const IntegrateArgs<S>& A, std::uint32_t begin, std::uint32_t end) {
  const S dt = A.dt, half_dt = S(0.5) * A.dt;
  for (std::uint32_t i = begin; i < end; ++i) {
    A.wx[i] = A.wx[i] + A.ax[i] * half_dt;
    A.wy[i] = A.wy[i] + A.ay[i] * half_dt;
    A.wz[i] = A.wz[i] + A.az[i] * half_dt;
    A.x[i] = A.x[i] + A.wx[i] * dt;
    A.y[i] = A.y[i] + A.wy[i] * dt;
    A.z[i] = A.z[i] + A.wz[i] * dt;
  }
}

SCULPT_CLONES float forces_portable(const ForceArgs<float>& a, ForceModel model, Velocity vel, std::uint32_t begin,
                                    std::uint32_t end, std::uint32_t ob, std::uint32_t oe) {
  return dispatch_forces(a, model, vel, begin, end, ob, oe);
}

#if defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES)
// Eight neighbours' {a, b, c, _} quadruples at p[l] + off, as three lanes of 8.
__attribute__((target("avx2"), always_inline)) inline void gather_lanes(const float* const* p, int off, __m256& ox,
                                                                         __m256& oy, __m256& oz) {
  const __m256 r0 = _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_load_ps(p[0] + off)), _mm_load_ps(p[4] + off), 1);
  const __m256 r1 = _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_load_ps(p[1] + off)), _mm_load_ps(p[5] + off), 1);
  const __m256 r2 = _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_load_ps(p[2] + off)), _mm_load_ps(p[6] + off), 1);
  const __m256 r3 = _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_load_ps(p[3] + off)), _mm_load_ps(p[7] + off), 1);
  const __m256 t0 = _mm256_unpacklo_ps(r0, r1), t1 = _mm256_unpacklo_ps(r2, r3);
  const __m256 t2 = _mm256_unpackhi_ps(r0, r1), t3 = _mm256_unpackhi_ps(r2, r3);
  ox = _mm256_shuffle_ps(t0, t1, _MM_SHUFFLE(1, 0, 1, 0));
  oy = _mm256_shuffle_ps(t0, t1, _MM_SHUFFLE(3, 2, 3, 2));
  oz = _mm256_shuffle_ps(t2, t3, _MM_SHUFFLE(1, 0, 1, 0));
}

// A group of eight vertices' force and energy sums, from and back to the scratch.
__attribute__((target("avx2"), always_inline)) inline void load_sums8(const BlockScratch<float>& w, std::uint32_t i,
                                                                        __m256& fx, __m256& fy, __m256& fz,
                                                                        __m256& pe) {
  fx = _mm256_load_ps(w.fx + i), fy = _mm256_load_ps(w.fy + i), fz = _mm256_load_ps(w.fz + i);
  pe = _mm256_load_ps(w.pe + i);
}
__attribute__((target("avx2"), always_inline)) inline void store_sums8(BlockScratch<float>& w, std::uint32_t i,
                                                                         __m256 fx, __m256 fy, __m256 fz, __m256 pe) {
  _mm256_store_ps(w.fx + i, fx);
  _mm256_store_ps(w.fy + i, fy);
  _mm256_store_ps(w.fz + i, fz);
  _mm256_store_ps(w.pe + i, pe);
}

// One spring per lane (linear model: d = u_j − u_i), pair_force's operations
// in its order without fused multiply-adds (identical bits).
__attribute__((target("avx2"), always_inline)) inline void linear_lanes(__m256 dx, __m256 dy, __m256 dz, __m256 dvx,
                                                                        __m256 dvy, __m256 dvz, __m256 k8, __m256 c8,
                                                                        __m256 qk8, __m256& fx, __m256& fy,
                                                                        __m256& fz, __m256& pe) {
  fx = _mm256_add_ps(fx, _mm256_add_ps(_mm256_mul_ps(k8, dx), _mm256_mul_ps(c8, dvx)));
  fy = _mm256_add_ps(fy, _mm256_add_ps(_mm256_mul_ps(k8, dy), _mm256_mul_ps(c8, dvy)));
  fz = _mm256_add_ps(fz, _mm256_add_ps(_mm256_mul_ps(k8, dz), _mm256_mul_ps(c8, dvz)));
  pe = _mm256_add_ps(pe, _mm256_mul_ps(qk8, _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)),
                                                          _mm256_mul_ps(dz, dz))));
}

// One spring per lane (spring model), pair_force's operations in its order
// without fused multiply-adds (identical bits): adds the force on the lane's
// vertex to f, its half energy to pe; returns the length.
__attribute__((target("avx2"), always_inline)) inline __m256 spring_lanes(__m256 dx, __m256 dy, __m256 dz, __m256 dvx,
                                                                          __m256 dvy, __m256 dvz, __m256 rest,
                                                                          __m256 k8, __m256 c8, __m256 qk8, __m256 one8,
                                                                          __m256 tiny8, __m256& fx, __m256& fy,
                                                                          __m256& fz, __m256& pe) {
  const __m256 len =
      _mm256_sqrt_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz)));
  const __m256 inv = _mm256_div_ps(one8, _mm256_add_ps(len, tiny8));
  const __m256 stretch = _mm256_sub_ps(len, rest);
  const __m256 dvd =
      _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dvx, dx), _mm256_mul_ps(dvy, dy)), _mm256_mul_ps(dvz, dz));
  const __m256 sc = _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(k8, stretch), inv),
                                  _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(c8, dvd), inv), inv));
  fx = _mm256_add_ps(fx, _mm256_mul_ps(sc, dx));
  fy = _mm256_add_ps(fy, _mm256_mul_ps(sc, dy));
  fz = _mm256_add_ps(fz, _mm256_mul_ps(sc, dz));
  pe = _mm256_add_ps(pe, _mm256_mul_ps(_mm256_mul_ps(qk8, stretch), stretch));
  return len;
}

// a[j[0]], …, a[j[7]] by scalar loads into lanes: vgatherdps took 1.3× the
// time here, for fewer instructions.
__attribute__((target("avx2"), always_inline)) inline __m256 gather8(const float* __restrict a, const std::int32_t* j) {
  return _mm256_setr_ps(a[j[0]], a[j[1]], a[j[2]], a[j[3]], a[j[4]], a[j[5]], a[j[6]], a[j[7]]);
}

// How accumulate_slots8 fetches the eight neighbours of one slot row (nb:
// offsets from the group's first vertex) as what pair_force compares: the
// position (linear model: u = p − r) and the velocity.
// From the packed records: two 16-byte loads and a transpose per eight.
// With Ring, every neighbour lies within kRingReach blocks (the ELL holds no
// farther one), so its record is at its index masked into the ring.
template <bool Ring = false>
struct FromRecords {
  const float* P;       // the records (Ring: the ring)
  std::uint32_t v;      // the group's first vertex
  std::uint32_t mask;   // Ring: the ring's index mask
  __attribute__((target("avx2"), always_inline)) void operator()(const std::int16_t* nb, __m256& xj, __m256& yj,
                                                                 __m256& zj, __m256& vxj, __m256& vyj,
                                                                 __m256& vzj) const {
    const float* p[8];
    if constexpr (Ring) {
      for (int l = 0; l < 8; ++l)
        p[l] = P + 8 * static_cast<std::size_t>((v + static_cast<std::uint32_t>(l + nb[l])) & mask);
    } else {
      const float* P8 = P + 8 * static_cast<std::size_t>(v);
      for (int l = 0; l < 8; ++l) p[l] = P8 + 8 * static_cast<std::ptrdiff_t>(l + nb[l]);
    }
    gather_lanes(p, 0, xj, yj, zj);
    gather_lanes(p, 4, vxj, vyj, vzj);
  }
};
// From the arrays, lane by lane (bodies without records): the same values
// the records would hold, by the same operations (w · 1/dt, p − r).
template <ForceModel M, Velocity V>
struct FromArrays {
  const ForceArgs<float>* A;
  std::uint32_t v;  // the group's first vertex
  __attribute__((target("avx2"), always_inline)) void operator()(const std::int16_t* nb, __m256& xj, __m256& yj,
                                                                 __m256& zj, __m256& vxj, __m256& vyj,
                                                                 __m256& vzj) const {
    std::int32_t j[8];
    for (int l = 0; l < 8; ++l) j[l] = static_cast<std::int32_t>(v) + l + nb[l];
    vxj = gather8(A->wx, j), vyj = gather8(A->wy, j), vzj = gather8(A->wz, j);
    if constexpr (V == Velocity::step) {
      const __m256 inv_dt8 = _mm256_set1_ps(A->inv_dt);
      vxj = _mm256_mul_ps(vxj, inv_dt8), vyj = _mm256_mul_ps(vyj, inv_dt8), vzj = _mm256_mul_ps(vzj, inv_dt8);
    }
    xj = gather8(A->x, j), yj = gather8(A->y, j), zj = gather8(A->z, j);
    if constexpr (M == ForceModel::linear) {
      xj = _mm256_sub_ps(xj, gather8(A->rx, j));
      yj = _mm256_sub_ps(yj, gather8(A->ry, j));
      zj = _mm256_sub_ps(zj, gather8(A->rz, j));
    }
  }
};

// The neighbour slots of eight consecutive vertices (nb0 and L0 at the first
// one's slot-0 entries), each row's neighbours from `fetch`. Every arithmetic
// step is the one pair_force() does, in the same order, without fused
// multiply-adds: identical bits. Accumulates into f and pe, in slot order.
// With Yield (spring model), also marks[s · kBlock/8] = the springs whose
// length is past ±yield of their rest length: World::plastic_flow's exact test
// (same length bits, same thresholds), from the length the force needs anyway.
template <ForceModel M, bool Yield = false, class Fetch>
__attribute__((target("avx2"), always_inline)) inline void accumulate_slots8(
    const Fetch& fetch, const std::int16_t* __restrict nb0, const float* __restrict L0, std::size_t stride,
    int slots, __m256 k8, __m256 c8, __m256 qk8, __m256 one8, __m256 tiny8, __m256 xi, __m256 yi, __m256 zi,
    __m256 vxi, __m256 vyi, __m256 vzi, __m256& fx, __m256& fy, __m256& fz, __m256& pe, __m256 up8, __m256 down8,
    std::uint8_t* marks) {
  for (int s = 0; s < slots; ++s) {
    __m256 xj, yj, zj, vxj, vyj, vzj;
    fetch(nb0 + s * stride, xj, yj, zj, vxj, vyj, vzj);
    const __m256 dx = _mm256_sub_ps(xj, xi), dy = _mm256_sub_ps(yj, yi), dz = _mm256_sub_ps(zj, zi);
    const __m256 dvx = _mm256_sub_ps(vxj, vxi), dvy = _mm256_sub_ps(vyj, vyi), dvz = _mm256_sub_ps(vzj, vzi);
    if constexpr (M == ForceModel::linear) {
      linear_lanes(dx, dy, dz, dvx, dvy, dvz, k8, c8, qk8, fx, fy, fz, pe);
    } else {
      const __m256 rest = _mm256_loadu_ps(L0 + s * stride);
      const __m256 len = spring_lanes(dx, dy, dz, dvx, dvy, dvz, rest, k8, c8, qk8, one8, tiny8, fx, fy, fz, pe);
      if constexpr (Yield) {
        const __m256 past = _mm256_or_ps(_mm256_cmp_ps(len, _mm256_mul_ps(rest, up8), _CMP_GT_OQ),
                                         _mm256_cmp_ps(len, _mm256_mul_ps(rest, down8), _CMP_LT_OQ));
        marks[static_cast<std::size_t>(s) * (kBlock / 8)] = static_cast<std::uint8_t>(_mm256_movemask_ps(past));
      }
    }
  }
}

// Eight vertices' own positions as the neighbour loops compare them: p, or
// for the linear model the displacement u = p − r (what its records hold).
template <ForceModel M>
__attribute__((target("avx2"), always_inline)) inline void own_position8(const ForceArgs<float>& A, std::uint32_t v,
                                                                           __m256& x, __m256& y, __m256& z) {
  x = _mm256_loadu_ps(A.x + v), y = _mm256_loadu_ps(A.y + v), z = _mm256_loadu_ps(A.z + v);
  if constexpr (M == ForceModel::linear) {
    x = _mm256_sub_ps(x, _mm256_loadu_ps(A.rx + v));
    y = _mm256_sub_ps(y, _mm256_loadu_ps(A.ry + v));
    z = _mm256_sub_ps(z, _mm256_loadu_ps(A.rz + v));
  }
}

// The neighbour loop with AVX2 intrinsics, 8 vertices at a time: neighbours
// from the packed records, or (Packed = false: bodies without them, the big
// ones) lane by lane from the arrays at vertex + 16-bit offset, where the
// compiler's own loop (forces_portable) extracts each offset from a vector
// first (~18% more instructions). Identical bits either way.
template <ForceModel M, Velocity V, bool Packed, bool Ring = false>
__attribute__((target("avx2"), always_inline)) inline void slots_avx2(const ForceArgs<float>& A, std::uint32_t begin,
                                                                       std::uint32_t cnt, BlockScratch<float>& w) {
  const float k = A.stiffness, c = A.damping, quarter_k = 0.25f * k;
  const __m256 k8 = _mm256_set1_ps(k), c8 = _mm256_set1_ps(c), qk8 = _mm256_set1_ps(quarter_k);
  const __m256 one8 = _mm256_set1_ps(1.0f), tiny8 = _mm256_set1_ps(Tiny<float>::value);
  // Vertex groups outside, slots inside: the accumulators stay in registers
  // and each vertex still sums its springs in slot order (same bits).
  const std::size_t stride = A.stride;
  const std::int16_t* __restrict nb0 = A.nbr + begin;
  const float* __restrict L0 = M == ForceModel::spring ? A.rest_length + begin : nullptr;  // linear: none
  std::uint32_t i = 0;
  for (; i + 8 <= cnt; i += 8) {
    const std::uint32_t v = begin + i;
    __m256 xi, yi, zi;
    own_position8<M>(A, v, xi, yi, zi);
    const __m256 vxi = _mm256_load_ps(w.vx + i), vyi = _mm256_load_ps(w.vy + i), vzi = _mm256_load_ps(w.vz + i);
    __m256 fx, fy, fz, pe;
    load_sums8(w, i, fx, fy, fz, pe);
    using Fetch = std::conditional_t<Packed, FromRecords<Ring>, FromArrays<M, V>>;
    Fetch fetch;
    if constexpr (Packed) fetch = {A.packed, v, A.ring_mask};
    else fetch = {&A, v};
    accumulate_slots8<M>(fetch, nb0 + i, M == ForceModel::spring ? L0 + i : nullptr, stride, A.slots, k8, c8, qk8, one8,
                         tiny8, xi, yi, zi, vxi, vyi, vzi, fx, fy, fz, pe, one8, one8, nullptr);
    store_sums8(w, i, fx, fy, fz, pe);
  }
  // The rest (a body's last block), one vertex at a time.
  for (; i < cnt; ++i) {
    const std::uint32_t v = begin + i;
    for (int s = 0; s < A.slots; ++s) {
      const std::int32_t j = static_cast<std::int32_t>(v) + nb0[s * stride + i];
      float xj, yj, zj, vxj, vyj, vzj;
      if constexpr (Packed) {
        const float* pj = A.packed + 8 * static_cast<std::size_t>(Ring ? static_cast<std::uint32_t>(j) & A.ring_mask
                                                                       : static_cast<std::uint32_t>(j));
        xj = pj[0], yj = pj[1], zj = pj[2], vxj = pj[4], vyj = pj[5], vzj = pj[6];
      } else {
        xj = A.x[j], yj = A.y[j], zj = A.z[j], vxj = A.wx[j], vyj = A.wy[j], vzj = A.wz[j];
        if constexpr (V == Velocity::step) vxj = vxj * A.inv_dt, vyj = vyj * A.inv_dt, vzj = vzj * A.inv_dt;
        if constexpr (M == ForceModel::linear) xj = xj - A.rx[j], yj = yj - A.ry[j], zj = zj - A.rz[j];
      }
      float xi = A.x[v], yi = A.y[v], zi = A.z[v], len = 0;
      if constexpr (M == ForceModel::linear) xi = xi - A.rx[v], yi = yi - A.ry[v], zi = zi - A.rz[v];
      else len = L0[s * stride + i];
      pair_force<float, M>(xj - xi, yj - yi, zj - zi, vxj - w.vx[i], vyj - w.vy[i], vzj - w.vz[i], 0, 0, 0, len, k, c,
                           quarter_k, w.fx[i], w.fy[i], w.fz[i], w.pe[i]);
    }
  }
}

// One block's forces on the AVX2 paths: neighbours from the packed records,
// or (Packed = false) lane by lane from the arrays.
template <ForceModel M, Velocity V, bool Packed = true, bool Ring = false>
__attribute__((target("avx2"), always_inline)) inline void forces_avx2_block(const ForceArgs<float>& A,
                                                                              std::uint32_t begin, std::uint32_t cnt,
                                                                              std::uint32_t ob, std::uint32_t oe,
                                                                              BlockScratch<float>& w) {
  init_block<float, V>(A, begin, cnt, w);
  slots_avx2<M, V, Packed, Ring>(A, begin, cnt, w);
  overflow_block<float, M, V, Packed, Ring>(A, begin, ob, oe, w);
}

// Forces for one block of a float body on an AVX2 CPU.
template <bool Packed, bool Ring = false>
__attribute__((target("avx2"))) float forces_avx2(const ForceArgs<float>& A, ForceModel model, Velocity vel,
                                                  std::uint32_t begin, std::uint32_t end, std::uint32_t ob,
                                                  std::uint32_t oe) {
  BlockScratch<float> w;
  const std::uint32_t cnt = end - begin;
  const bool bd = vel == Velocity::step;
  if (model == ForceModel::spring) {
    if (bd) forces_avx2_block<ForceModel::spring, Velocity::step, Packed, Ring>(A, begin, cnt, ob, oe, w);
    else forces_avx2_block<ForceModel::spring, Velocity::stored, Packed, Ring>(A, begin, cnt, ob, oe, w);
  } else {
    if (bd) forces_avx2_block<ForceModel::linear, Velocity::step, Packed, Ring>(A, begin, cnt, ob, oe, w);
    else forces_avx2_block<ForceModel::linear, Velocity::stored, Packed, Ring>(A, begin, cnt, ob, oe, w);
  }
  return write_acc<float>(A, begin, cnt, w);
}
#endif

std::atomic<bool> g_portable{false};
std::atomic<bool> g_block_pieces{false};

#if defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES)
// Decided once at load time, so the real-time thread never meets a
// function-local static's first-use guard.
bool detect_avx2() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2");
}
const bool g_has_avx2 = detect_avx2();
#endif

}  // namespace

void testing::force_portable(bool on) { g_portable.store(on, std::memory_order_relaxed); }
void testing::force_block_pieces(bool on) { g_block_pieces.store(on, std::memory_order_relaxed); }

bool avx2_paths_active() {
#if defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES)
  return g_has_avx2 && !g_portable.load(std::memory_order_relaxed);
#else
  return false;
#endif
}

float forces(const ForceArgs<float>& a, ForceModel model, Velocity vel, std::uint32_t begin, std::uint32_t end,
             std::uint32_t ob, std::uint32_t oe) {
#if defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES)
  if (avx2_paths_active()) {
    if (a.packed && a.ring_mask) return forces_avx2<true, true>(a, model, vel, begin, end, ob, oe);
    return a.packed ? forces_avx2<true>(a, model, vel, begin, end, ob, oe)
                    : forces_avx2<false>(a, model, vel, begin, end, ob, oe);
  }
#endif
  return forces_portable(a, model, vel, begin, end, ob, oe);
}

SCULPT_CLONES double forces(const ForceArgs<double>& a, ForceModel model, Velocity vel, std::uint32_t begin,
                            std::uint32_t end, std::uint32_t ob, std::uint32_t oe) {
  return dispatch_forces(a, model, vel, begin, end, ob, oe);
}


namespace {

// out: vertex begin's record.
template <Velocity V, ForceModel M>
[[gnu::always_inline]] inline void pack_loop(const ForceArgs<float>& A, float* __restrict out, std::uint32_t begin,
                                             std::uint32_t end) {
  for (std::uint32_t i = begin; i < end; ++i) {
    float* q = out + 8 * static_cast<std::size_t>(i - begin);
    if constexpr (M == ForceModel::linear) q[0] = A.x[i] - A.rx[i], q[1] = A.y[i] - A.ry[i], q[2] = A.z[i] - A.rz[i];
    else q[0] = A.x[i], q[1] = A.y[i], q[2] = A.z[i];
    q[3] = 0.0f;
    if constexpr (V == Velocity::step) {
      q[4] = A.wx[i] * A.inv_dt;
      q[5] = A.wy[i] * A.inv_dt;
      q[6] = A.wz[i] * A.inv_dt;
    } else {
      q[4] = A.wx[i], q[5] = A.wy[i], q[6] = A.wz[i];
    }
    q[7] = 0.0f;
  }
}

#if defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES)
// Eight vertices' rows (x y z, vx vy vz; two implicit zero rows) transposed
// 8×8 into eight {x,y,z,0,vx,vy,vz,0} records at q (32-byte aligned).
__attribute__((target("avx2"), always_inline)) inline void store_packed8(float* q, __m256 ox, __m256 oy, __m256 oz,
                                                                        __m256 vx, __m256 vy, __m256 vz) {
  const __m256 zero = _mm256_setzero_ps();
  // Rows a0..a3 = x y z 0 and b0..b3 = vx vy vz 0: 4×4 transposes per 128-bit lane.
  const __m256 t0 = _mm256_unpacklo_ps(ox, oy), t1 = _mm256_unpackhi_ps(ox, oy);
  const __m256 t2 = _mm256_unpacklo_ps(oz, zero), t3 = _mm256_unpackhi_ps(oz, zero);
  const __m256 a0 = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(1, 0, 1, 0));  // vertices 0,4
  const __m256 a1 = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(3, 2, 3, 2));  // 1,5
  const __m256 a2 = _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(1, 0, 1, 0));  // 2,6
  const __m256 a3 = _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(3, 2, 3, 2));  // 3,7
  const __m256 u0 = _mm256_unpacklo_ps(vx, vy), u1 = _mm256_unpackhi_ps(vx, vy);
  const __m256 u2 = _mm256_unpacklo_ps(vz, zero), u3 = _mm256_unpackhi_ps(vz, zero);
  const __m256 b0 = _mm256_shuffle_ps(u0, u2, _MM_SHUFFLE(1, 0, 1, 0));
  const __m256 b1 = _mm256_shuffle_ps(u0, u2, _MM_SHUFFLE(3, 2, 3, 2));
  const __m256 b2 = _mm256_shuffle_ps(u1, u3, _MM_SHUFFLE(1, 0, 1, 0));
  const __m256 b3 = _mm256_shuffle_ps(u1, u3, _MM_SHUFFLE(3, 2, 3, 2));
  _mm256_store_ps(q + 0, _mm256_permute2f128_ps(a0, b0, 0x20));
  _mm256_store_ps(q + 8, _mm256_permute2f128_ps(a1, b1, 0x20));
  _mm256_store_ps(q + 16, _mm256_permute2f128_ps(a2, b2, 0x20));
  _mm256_store_ps(q + 24, _mm256_permute2f128_ps(a3, b3, 0x20));
  _mm256_store_ps(q + 32, _mm256_permute2f128_ps(a0, b0, 0x31));
  _mm256_store_ps(q + 40, _mm256_permute2f128_ps(a1, b1, 0x31));
  _mm256_store_ps(q + 48, _mm256_permute2f128_ps(a2, b2, 0x31));
  _mm256_store_ps(q + 56, _mm256_permute2f128_ps(a3, b3, 0x31));
}

// Eight vertices at a time: six rows (x y z vx vy vz) and two zero rows,
// transposed 8×8 into eight {x,y,z,0,vx,vy,vz,0} records.
// out: vertex begin's record.
template <Velocity V, ForceModel M>
__attribute__((target("avx2"))) void pack_avx2(const ForceArgs<float>& A, float* __restrict out,
                                               std::uint32_t begin, std::uint32_t end) {
  std::uint32_t i = begin;
  const __m256 inv_dt = _mm256_set1_ps(A.inv_dt);
  for (; i + 8 <= end; i += 8) {
    const __m256 x = _mm256_loadu_ps(A.x + i), y = _mm256_loadu_ps(A.y + i), z = _mm256_loadu_ps(A.z + i);
    __m256 ox = x, oy = y, oz = z;  // what neighbours read: p (spring) or u = p − r (linear)
    if constexpr (M == ForceModel::linear) {
      ox = _mm256_sub_ps(x, _mm256_loadu_ps(A.rx + i));
      oy = _mm256_sub_ps(y, _mm256_loadu_ps(A.ry + i));
      oz = _mm256_sub_ps(z, _mm256_loadu_ps(A.rz + i));
    }
    __m256 vx, vy, vz;
    if constexpr (V == Velocity::step) {
      vx = _mm256_mul_ps(_mm256_loadu_ps(A.wx + i), inv_dt);
      vy = _mm256_mul_ps(_mm256_loadu_ps(A.wy + i), inv_dt);
      vz = _mm256_mul_ps(_mm256_loadu_ps(A.wz + i), inv_dt);
    } else {
      vx = _mm256_loadu_ps(A.wx + i), vy = _mm256_loadu_ps(A.wy + i), vz = _mm256_loadu_ps(A.wz + i);
    }
    store_packed8(out + 8 * static_cast<std::size_t>(i - begin), ox, oy, oz, vx, vy, vz);
  }
  pack_loop<V, M>(A, out + 8 * static_cast<std::size_t>(i - begin), i, end);
}
#endif

}  // namespace

void pack(const ForceArgs<float>& A, ForceModel model, Velocity vel, float* packed, std::uint32_t begin,
          std::uint32_t end) {
  pack_into(A, model, vel, packed + 8 * static_cast<std::size_t>(begin), begin, end);
}

void pack_into(const ForceArgs<float>& A, ForceModel model, Velocity vel, float* packed, std::uint32_t begin,
               std::uint32_t end) {
  const bool bd = vel == Velocity::step, lin = model == ForceModel::linear;
#if defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES)
  if (g_has_avx2) {
    if (bd && !lin) pack_avx2<Velocity::step, ForceModel::spring>(A, packed, begin, end);
    else if (bd) pack_avx2<Velocity::step, ForceModel::linear>(A, packed, begin, end);
    else if (!lin) pack_avx2<Velocity::stored, ForceModel::spring>(A, packed, begin, end);
    else pack_avx2<Velocity::stored, ForceModel::linear>(A, packed, begin, end);
    return;
  }
#endif
  if (bd && !lin) pack_loop<Velocity::step, ForceModel::spring>(A, packed, begin, end);
  else if (bd) pack_loop<Velocity::step, ForceModel::linear>(A, packed, begin, end);
  else if (!lin) pack_loop<Velocity::stored, ForceModel::spring>(A, packed, begin, end);
  else pack_loop<Velocity::stored, ForceModel::linear>(A, packed, begin, end);
}

SCULPT_CLONES BlockSums<float> integrate(const IntegrateArgs<float>& a, Integrator integrator, std::uint32_t begin,
                                         std::uint32_t end) {
  return dispatch_integrate(a, integrator, begin, end);
}
SCULPT_CLONES BlockSums<double> integrate(const IntegrateArgs<double>& a, Integrator integrator,
                                          std::uint32_t begin, std::uint32_t end) {
  return dispatch_integrate(a, integrator, begin, end);
}
void vv_open(const IntegrateArgs<float>& a, std::uint32_t begin, std::uint32_t end) { vv_open_impl(a, begin, end); }
void vv_open(const IntegrateArgs<double>& a, std::uint32_t begin, std::uint32_t end) { vv_open_impl(a, begin, end); }

#if defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES)
namespace {

template <ForceModel M, Velocity V, Integrator I, bool Ring = false>
__attribute__((target("avx2"))) BlockSums<float> fused_avx2(const ForceArgs<float>& A, const IntegrateArgs<float>& In,
                                                            std::uint32_t begin, std::uint32_t end, std::uint32_t ob,
                                                            std::uint32_t oe, float* packed_next, float& potential) {
  BlockScratch<float> w;
  const std::uint32_t cnt = end - begin;
  forces_avx2_block<M, V, true, Ring>(A, begin, cnt, ob, oe, w);
  potential = sum8(w.pe, cnt);
  const float inv_m = A.inv_mass;
  for (std::uint32_t i = 0; i < cnt; ++i) {  // the same a = f/m the acceleration buffer would hold
    w.fx[i] = w.fx[i] * inv_m;
    w.fy[i] = w.fy[i] * inv_m;
    w.fz[i] = w.fz[i] * inv_m;
  }
  alignas(64) float sp[kBlock];
  alignas(64) std::uint32_t bits[kBlock];
  integrate_loop<float, I>(In.x + begin, In.y + begin, In.z + begin, In.wx + begin, In.wy + begin, In.wz + begin,
                           w.fx, w.fy, w.fz, In.dt, In.inv_dt, cnt, sp);
  std::memcpy(bits, sp, sizeof(float) * cnt);
  std::uint32_t m = 0;
  for (std::uint32_t i = 0; i < cnt; ++i) m = bits[i] > m ? bits[i] : m;
  if constexpr (!Ring) pack_avx2<V, M>(A, packed_next + 8 * static_cast<std::size_t>(begin), begin, end);
  return {sum8(sp, cnt), m};
}


// Horizontal pieces of the deterministic reductions, in sum8()'s fixed tree.
__attribute__((target("avx2"), always_inline)) inline float tree_sum8(__m256 v) {
  alignas(32) float p[8];
  _mm256_store_ps(p, v);
  return ((p[0] + p[1]) + (p[2] + p[3])) + ((p[4] + p[5]) + (p[6] + p[7]));
}
__attribute__((target("avx2"), always_inline)) inline std::uint32_t max_u32x8(__m256i v) {
  alignas(32) std::uint32_t p[8];
  _mm256_store_si256(reinterpret_cast<__m256i*>(p), v);
  std::uint32_t m = 0;
  for (int l = 0; l < 8; ++l) m = p[l] > m ? p[l] : m;
  return m;
}

// Integrates eight vertices of a block from their forces and packs them into
// packed_next (the tail of fused_full_block_avx2).
struct Finish8 {
  __m256 inv_m, dt, dt2, in_inv_dt;
  float *X, *Y, *Z, *WX, *WY, *WZ;
  const float *RX, *RY, *RZ;
  float* packed_next;  // at the block's first record
  __m256 sp_sum;
  __m256i sp_max;
};
template <ForceModel M, Integrator I, bool Ring = false>
__attribute__((target("avx2"), always_inline)) inline void finish8(Finish8& F, std::uint32_t i, __m256 fx, __m256 fy,
                                                                  __m256 fz) {
  const __m256 inv_m = F.inv_m, dt = F.dt, dt2 = F.dt2, in_inv_dt = F.in_inv_dt;
  float* __restrict X = F.X;
  float* __restrict Y = F.Y;
  float* __restrict Z = F.Z;
  float* __restrict WX = F.WX;
  float* __restrict WY = F.WY;
  float* __restrict WZ = F.WZ;
  const __m256 ax = _mm256_mul_ps(fx, inv_m), ay = _mm256_mul_ps(fy, inv_m), az = _mm256_mul_ps(fz, inv_m);
  __m256 ux, uy, uz, nx, ny, nz;
  if constexpr (I == Integrator::position_verlet) {
    const __m256 dx = _mm256_add_ps(_mm256_load_ps(WX + i), _mm256_mul_ps(ax, dt2));
    const __m256 dy = _mm256_add_ps(_mm256_load_ps(WY + i), _mm256_mul_ps(ay, dt2));
    const __m256 dz = _mm256_add_ps(_mm256_load_ps(WZ + i), _mm256_mul_ps(az, dt2));
    _mm256_store_ps(WX + i, dx);
    _mm256_store_ps(WY + i, dy);
    _mm256_store_ps(WZ + i, dz);
    nx = _mm256_add_ps(_mm256_load_ps(X + i), dx);
    ny = _mm256_add_ps(_mm256_load_ps(Y + i), dy);
    nz = _mm256_add_ps(_mm256_load_ps(Z + i), dz);
    ux = _mm256_mul_ps(dx, in_inv_dt);
    uy = _mm256_mul_ps(dy, in_inv_dt);
    uz = _mm256_mul_ps(dz, in_inv_dt);
  } else {  // symplectic Euler
    ux = _mm256_add_ps(_mm256_load_ps(WX + i), _mm256_mul_ps(ax, dt));
    uy = _mm256_add_ps(_mm256_load_ps(WY + i), _mm256_mul_ps(ay, dt));
    uz = _mm256_add_ps(_mm256_load_ps(WZ + i), _mm256_mul_ps(az, dt));
    _mm256_store_ps(WX + i, ux);
    _mm256_store_ps(WY + i, uy);
    _mm256_store_ps(WZ + i, uz);
    nx = _mm256_add_ps(_mm256_load_ps(X + i), _mm256_mul_ps(ux, dt));
    ny = _mm256_add_ps(_mm256_load_ps(Y + i), _mm256_mul_ps(uy, dt));
    nz = _mm256_add_ps(_mm256_load_ps(Z + i), _mm256_mul_ps(uz, dt));
  }
  _mm256_store_ps(X + i, nx);
  _mm256_store_ps(Y + i, ny);
  _mm256_store_ps(Z + i, nz);
  const __m256 sp = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ux, ux), _mm256_mul_ps(uy, uy)), _mm256_mul_ps(uz, uz));
  F.sp_sum = _mm256_add_ps(F.sp_sum, sp);
  F.sp_max = _mm256_max_epu32(F.sp_max, _mm256_castps_si256(sp));
  if constexpr (Ring) return;  // the ring keeps the step's start; nothing reads the new state this substep
  // What pack_avx2 would compute from the arrays just written: for Verlet
  // w·inv_dt with w = d is ux itself (World sets both inv_dt as 1/dts), so
  // the velocity rows are ux, uy, uz.
  __m256 px = nx, py = ny, pz = nz;
  if constexpr (M == ForceModel::linear) {
    px = _mm256_sub_ps(nx, _mm256_load_ps(F.RX + i));
    py = _mm256_sub_ps(ny, _mm256_load_ps(F.RY + i));
    pz = _mm256_sub_ps(nz, _mm256_load_ps(F.RZ + i));
  }
  store_packed8(F.packed_next + 8 * static_cast<std::size_t>(i), px, py, pz, ux, uy, uz);
}

// A whole block (kBlock vertices) in one pass over groups of eight, with the
// state in registers: anchor and own velocity, neighbour slots, integrate,
// speed sums, pack. The same IEEE operations in the same order as
// forces_avx2_block + write_acc + integrate_loop + pack_avx2 (identical bits),
// without the scalar prologue loops, the acceleration round trip and the
// re-reads. Blocks with overflow neighbours keep the forces in the scratch
// until their extras are added (a vertex sums slots first, then extras).
template <ForceModel M, Velocity V, Integrator I, bool Yield = false, bool Ring = false>
__attribute__((target("avx2"))) BlockSums<float> fused_full_block_avx2(const ForceArgs<float>& A,
                                                                       const IntegrateArgs<float>& In,
                                                                       std::uint32_t begin, std::uint32_t ob,
                                                                       std::uint32_t oe, float* packed_next,
                                                                       float& potential, const YieldArgs* ya = nullptr) {
  static_assert(kBlock % 8 == 0);
  static_assert(!Yield || M == ForceModel::spring, "yield marks: spring model only");
  __m256 up8{}, down8{}, limit8{};
  std::uint8_t* marks = nullptr;
  if constexpr (Yield) {
    up8 = _mm256_set1_ps(1.0f + ya->yield), down8 = _mm256_set1_ps(1.0f - ya->yield);
    limit8 = _mm256_set1_ps(ya->anchor_limit);
    marks = ya->mask;
  }
  const float k = A.stiffness, c = A.damping;
  const __m256 k8 = _mm256_set1_ps(k), c8 = _mm256_set1_ps(c), qk8 = _mm256_set1_ps(0.25f * k);
  const __m256 one8 = _mm256_set1_ps(1.0f), tiny8 = _mm256_set1_ps(Tiny<float>::value);
  const __m256 inv_dt = _mm256_set1_ps(A.inv_dt), ka = _mm256_set1_ps(A.anchor), ca = _mm256_set1_ps(A.anchor_damping);
  const __m256 half_ka = _mm256_set1_ps(0.5f * A.anchor);
  const __m256 gx = _mm256_set1_ps(A.gravity_force[0]), gy = _mm256_set1_ps(A.gravity_force[1]),
               gz = _mm256_set1_ps(A.gravity_force[2]);
  const __m256 inv_m = _mm256_set1_ps(A.inv_mass);
  const float dt_s = In.dt;
  const __m256 dt = _mm256_set1_ps(dt_s), dt2 = _mm256_set1_ps(dt_s * dt_s);
  const __m256 in_inv_dt = _mm256_set1_ps(In.inv_dt);
  const std::size_t stride = A.stride;
  const float* __restrict P = A.packed;
  const std::int16_t* __restrict nb0 = A.nbr + begin;
  const float* __restrict L0 = M == ForceModel::spring ? A.rest_length + begin : nullptr;
  float* __restrict X = In.x + begin;
  float* __restrict Y = In.y + begin;
  float* __restrict Z = In.z + begin;
  float* __restrict WX = In.wx + begin;
  float* __restrict WY = In.wy + begin;
  float* __restrict WZ = In.wz + begin;
  const float* __restrict RX = A.rx + begin;
  const float* __restrict RY = A.ry + begin;
  const float* __restrict RZ = A.rz + begin;
  const bool extras = oe > ob;
  BlockScratch<float> w;
  __m256 pe_sum = _mm256_setzero_ps();
  Finish8 F{inv_m, dt, dt2, in_inv_dt, X, Y, Z, WX, WY, WZ, RX, RY, RZ,
            Ring ? nullptr : packed_next + 8 * static_cast<std::size_t>(begin), _mm256_setzero_ps(),
            _mm256_setzero_si256()};


  for (std::uint32_t i = 0; i < kBlock; i += 8) {
    const __m256 x = _mm256_load_ps(X + i), y = _mm256_load_ps(Y + i), z = _mm256_load_ps(Z + i);
    __m256 vx, vy, vz;
    if constexpr (V == Velocity::step) {
      vx = _mm256_mul_ps(_mm256_load_ps(WX + i), inv_dt);
      vy = _mm256_mul_ps(_mm256_load_ps(WY + i), inv_dt);
      vz = _mm256_mul_ps(_mm256_load_ps(WZ + i), inv_dt);
    } else {
      vx = _mm256_load_ps(WX + i), vy = _mm256_load_ps(WY + i), vz = _mm256_load_ps(WZ + i);
    }
    const __m256 rx = _mm256_load_ps(RX + i), ry = _mm256_load_ps(RY + i), rz = _mm256_load_ps(RZ + i);
    // Anchor, its damper and gravity (init_block).
    const __m256 dx = _mm256_sub_ps(rx, x), dy = _mm256_sub_ps(ry, y), dz = _mm256_sub_ps(rz, z);
    __m256 fx = _mm256_add_ps(_mm256_sub_ps(_mm256_mul_ps(ka, dx), _mm256_mul_ps(ca, vx)), gx);
    __m256 fy = _mm256_add_ps(_mm256_sub_ps(_mm256_mul_ps(ka, dy), _mm256_mul_ps(ca, vy)), gy);
    __m256 fz = _mm256_add_ps(_mm256_sub_ps(_mm256_mul_ps(ka, dz), _mm256_mul_ps(ca, vz)), gz);
    __m256 pe = _mm256_add_ps(
        _mm256_mul_ps(half_ka, _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)),
                                             _mm256_mul_ps(dz, dz))),
        _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(gx, dx), _mm256_mul_ps(gy, dy)), _mm256_mul_ps(gz, dz)));
    if constexpr (Yield) {  // plastic_flow's anchor test: |x − r| > limit (the same squares, the same sums)
      const __m256 u = _mm256_sqrt_ps(
          _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz)));
      marks[i / 8] = static_cast<std::uint8_t>(_mm256_movemask_ps(_mm256_cmp_ps(u, limit8, _CMP_GT_OQ)));
    }
    __m256 xi = x, yi = y, zi = z;
    if constexpr (M == ForceModel::linear) xi = _mm256_sub_ps(x, rx), yi = _mm256_sub_ps(y, ry), zi = _mm256_sub_ps(z, rz);
    accumulate_slots8<M, Yield>(FromRecords<Ring>{P, begin + i, A.ring_mask}, nb0 + i,
                                M == ForceModel::spring ? L0 + i : nullptr, stride, A.slots, k8, c8, qk8,
                                one8, tiny8, xi, yi, zi, vx, vy, vz, fx, fy, fz, pe, up8, down8,
                                marks ? marks + kBlock / 8 + i / 8 : nullptr);
    if (extras) {
      _mm256_store_ps(w.fx + i, fx), _mm256_store_ps(w.fy + i, fy), _mm256_store_ps(w.fz + i, fz);
      _mm256_store_ps(w.pe + i, pe);
      _mm256_store_ps(w.vx + i, vx), _mm256_store_ps(w.vy + i, vy), _mm256_store_ps(w.vz + i, vz);
    } else {
      pe_sum = _mm256_add_ps(pe_sum, pe);
      finish8<M, I, Ring>(F, i, fx, fy, fz);
    }
  }
  if (extras) {
    overflow_block<float, M, V, true, Ring>(A, begin, ob, oe, w);
    for (std::uint32_t i = 0; i < kBlock; i += 8) {
      pe_sum = _mm256_add_ps(pe_sum, _mm256_load_ps(w.pe + i));
      finish8<M, I, Ring>(F, i, _mm256_load_ps(w.fx + i), _mm256_load_ps(w.fy + i), _mm256_load_ps(w.fz + i));
    }
  }
  potential = tree_sum8(pe_sum);
  return {tree_sum8(F.sp_sum), max_u32x8(F.sp_max)};
}

}  // namespace
#endif

#if defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES)
namespace {
// A whole block in one pass of eight-vertex groups, or a body's last, partial
// block in pieces; with Ring, through the ring of records (nothing packed after).
template <ForceModel M, Velocity V, Integrator I, bool Ring>
BlockSums<float> fused_block(const ForceArgs<float>& a, const IntegrateArgs<float>& in, bool whole,
                             std::uint32_t begin, std::uint32_t end, std::uint32_t ob, std::uint32_t oe,
                             float* packed_next, float& potential) {
  return whole ? fused_full_block_avx2<M, V, I, false, Ring>(a, in, begin, ob, oe, packed_next, potential)
               : fused_avx2<M, V, I, Ring>(a, in, begin, end, ob, oe, packed_next, potential);
}
template <bool Ring>
BlockSums<float> fused_dispatch(const ForceArgs<float>& a, const IntegrateArgs<float>& in, bool spring,
                                Integrator integrator, bool whole, std::uint32_t begin, std::uint32_t end,
                                std::uint32_t ob, std::uint32_t oe, float* packed_next, float& potential) {
  constexpr auto SP = ForceModel::spring;
  constexpr auto LI = ForceModel::linear;
  if (integrator == Integrator::position_verlet) {
    constexpr auto BD = Velocity::step;
    constexpr auto PV = Integrator::position_verlet;
    return spring ? fused_block<SP, BD, PV, Ring>(a, in, whole, begin, end, ob, oe, packed_next, potential)
                  : fused_block<LI, BD, PV, Ring>(a, in, whole, begin, end, ob, oe, packed_next, potential);
  }
  constexpr auto ST = Velocity::stored;
  constexpr auto SE = Integrator::symplectic_euler;
  return spring ? fused_block<SP, ST, SE, Ring>(a, in, whole, begin, end, ob, oe, packed_next, potential)
                : fused_block<LI, ST, SE, Ring>(a, in, whole, begin, end, ob, oe, packed_next, potential);
}
}  // namespace
#endif

BlockSums<float> step_block_fused(const ForceArgs<float>& a, const IntegrateArgs<float>& in, ForceModel model,
                                  Integrator integrator, std::uint32_t begin, std::uint32_t end, std::uint32_t ob,
                                  std::uint32_t oe, float* packed_next, float& potential, const YieldArgs* yield) {
  const bool spring = model == ForceModel::spring;
  [[maybe_unused]] const bool whole = end - begin == kBlock && !g_block_pieces.load(std::memory_order_relaxed);
  [[maybe_unused]] const bool avx2 = avx2_paths_active() && integrator != Integrator::velocity_verlet;
#if defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES)
  // Clay (double buffer only: World keeps clay off the ring): the marks come with the forces.
  if (avx2 && !a.ring_mask && yield && spring && whole) {
    if (integrator == Integrator::position_verlet)
      return fused_full_block_avx2<ForceModel::spring, Velocity::step, Integrator::position_verlet, true>(
          a, in, begin, ob, oe, packed_next, potential, yield);
    return fused_full_block_avx2<ForceModel::spring, Velocity::stored, Integrator::symplectic_euler, true>(
        a, in, begin, ob, oe, packed_next, potential, yield);
  }
#endif
  // Otherwise from the state before this block moves.
  if (yield) yield_candidates(a, yield->yield, yield->anchor_limit, spring, begin, end, yield->mask);
#if defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES)
  if (avx2)
    return a.ring_mask ? fused_dispatch<true>(a, in, spring, integrator, whole, begin, end, ob, oe, nullptr, potential)
                       : fused_dispatch<false>(a, in, spring, integrator, whole, begin, end, ob, oe, packed_next,
                                               potential);
#endif
  // The portable clones (the ring's path without AVX2), in the unfused order.
  const Velocity vel =
      integrator == Integrator::position_verlet ? Velocity::step : Velocity::stored;
  potential = forces(a, model, vel, begin, end, ob, oe);
  const BlockSums<float> sums = integrate(in, integrator, begin, end);
  if (packed_next) pack(a, model, vel, packed_next, begin, end);
  return sums;
}

// --- clay: which entries of a block might yield ---------------------------------
// Squared lengths against thresholds pulled in by a relative 1e-4 (far more
// than the rounding of a square, a product and a sqrt), so an entry left
// unmarked is one the exact test (sqrt, compare) would leave alone: the exact
// test then runs only on marked entries and the results are the same bits.
namespace {

template <class S>
inline constexpr S kYieldShrink = S(1) - S(1e-4);
template <class S>
inline constexpr S kYieldGrow = S(1) + S(1e-4);

template <class S>
[[gnu::always_inline]] inline bool anchor_quiet(S ux, S uy, S uz, S thr2) {
  return ux * ux + uy * uy + uz * uz <= thr2;
}

template <class S>
[[gnu::always_inline]] inline bool spring_quiet(S dx, S dy, S dz, S L, S y) {
  const S hi = L * (S(1) + y), lo = L * (S(1) - y);
  const S d2 = dx * dx + dy * dy + dz * dz;
  return d2 <= (hi * hi) * kYieldShrink<S> && d2 >= (lo * lo) * kYieldGrow<S>;
}

template <class S>
bool yield_candidates_scalar(const ForceArgs<S>& a, S yield, S anchor_limit, bool springs, std::uint32_t begin,
                             std::uint32_t end, std::uint8_t* mask) {
  constexpr std::uint32_t kRow = kBlock / 8;
  std::memset(mask, 0, kRow * (1 + (springs ? a.slots : 0)));
  const S thr2 = (anchor_limit * anchor_limit) * kYieldShrink<S>;
  bool any = false;
  for (std::uint32_t i = begin; i < end; ++i)
    if (!anchor_quiet(a.x[i] - a.rx[i], a.y[i] - a.ry[i], a.z[i] - a.rz[i], thr2)) {
      mask[(i - begin) / 8] |= static_cast<std::uint8_t>(1u << ((i - begin) % 8));
      any = true;
    }
  if (!springs) return any;
  for (int s = 0; s < a.slots; ++s) {
    std::uint8_t* row = mask + kRow * (1 + s);
    const std::size_t o = static_cast<std::size_t>(s) * a.stride;
    for (std::uint32_t i = begin; i < end; ++i) {
      const std::int32_t j = static_cast<std::int32_t>(i) + a.nbr[o + i];
      if (!spring_quiet(a.x[j] - a.x[i], a.y[j] - a.y[i], a.z[j] - a.z[i], a.rest_length[o + i], yield)) {
        row[(i - begin) / 8] |= static_cast<std::uint8_t>(1u << ((i - begin) % 8));
        any = true;
      }
    }
  }
  return any;
}

#if defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES)
// Eight vertices at a time; tails go scalar. Neighbours come from the packed
// records when there are any (two 16-byte loads and a transpose per eight, as
// in the force kernel), else lane by lane (gather8): vgatherdps made the whole
// clay step on the 164k sphere ~10% slower (BM_StepClaySculpting/7/0).
__attribute__((target("avx2"))) bool yield_candidates_avx2(const ForceArgs<float>& a, float yield,
                                                           float anchor_limit, bool springs, std::uint32_t begin,
                                                           std::uint32_t end, std::uint8_t* mask_out) {
  constexpr std::uint32_t kRow = kBlock / 8;
  // Pointers in locals: the byte stores below could alias anything in `a`.
  const float* __restrict X = a.x;
  const float* __restrict Y = a.y;
  const float* __restrict Z = a.z;
  const float* __restrict P = a.packed;
  const std::size_t stride = a.stride;
  const int slots = springs ? a.slots : 0;
  alignas(16) std::uint8_t mask[kRow];
  const std::uint32_t whole = begin + (end - begin) / 8 * 8;
  const float thr2s = (anchor_limit * anchor_limit) * kYieldShrink<float>;
  const __m256 thr2 = _mm256_set1_ps(thr2s);
  unsigned any = 0;
  std::memset(mask, 0, kRow);
  for (std::uint32_t i = begin; i < whole; i += 8) {
    const __m256 ux = _mm256_sub_ps(_mm256_loadu_ps(X + i), _mm256_loadu_ps(a.rx + i));
    const __m256 uy = _mm256_sub_ps(_mm256_loadu_ps(Y + i), _mm256_loadu_ps(a.ry + i));
    const __m256 uz = _mm256_sub_ps(_mm256_loadu_ps(Z + i), _mm256_loadu_ps(a.rz + i));
    const __m256 u2 =
        _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ux, ux), _mm256_mul_ps(uy, uy)), _mm256_mul_ps(uz, uz));
    const unsigned m = ~static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(u2, thr2, _CMP_LE_OQ))) & 0xffu;
    mask[(i - begin) / 8] = static_cast<std::uint8_t>(m);
    any |= m;
  }
  for (std::uint32_t i = whole; i < end; ++i)
    if (!anchor_quiet(X[i] - a.rx[i], Y[i] - a.ry[i], Z[i] - a.rz[i], thr2s)) {
      mask[(i - begin) / 8] |= static_cast<std::uint8_t>(1u << ((i - begin) % 8));
      any = 1;
    }
  std::memcpy(mask_out, mask, kRow);
  const __m256 up = _mm256_set1_ps(1.0f + yield), down = _mm256_set1_ps(1.0f - yield);
  const __m256 shrink = _mm256_set1_ps(kYieldShrink<float>), grow = _mm256_set1_ps(kYieldGrow<float>);
  for (int s = 0; s < slots; ++s) {
    const std::int16_t* __restrict nb = a.nbr + s * stride;
    const float* __restrict L = a.rest_length + s * stride;
    std::memset(mask, 0, kRow);
    for (std::uint32_t i = begin; i < whole; i += 8) {
      __m256 xj, yj, zj;
      if (P) {
        const float* p[8];
        for (int l = 0; l < 8; ++l)
          p[l] = P + 8 * static_cast<std::size_t>(static_cast<std::int32_t>(i + l) + nb[i + l]);
        gather_lanes(p, 0, xj, yj, zj);
      } else {
        std::int32_t j[8];
        for (int l = 0; l < 8; ++l) j[l] = static_cast<std::int32_t>(i) + l + nb[i + l];
        xj = gather8(X, j), yj = gather8(Y, j), zj = gather8(Z, j);
      }
      const __m256 dx = _mm256_sub_ps(xj, _mm256_loadu_ps(X + i));
      const __m256 dy = _mm256_sub_ps(yj, _mm256_loadu_ps(Y + i));
      const __m256 dz = _mm256_sub_ps(zj, _mm256_loadu_ps(Z + i));
      const __m256 d2 =
          _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
      const __m256 l8 = _mm256_loadu_ps(L + i);
      const __m256 hi = _mm256_mul_ps(l8, up), lo = _mm256_mul_ps(l8, down);
      const __m256 quiet =
          _mm256_and_ps(_mm256_cmp_ps(d2, _mm256_mul_ps(_mm256_mul_ps(hi, hi), shrink), _CMP_LE_OQ),
                        _mm256_cmp_ps(d2, _mm256_mul_ps(_mm256_mul_ps(lo, lo), grow), _CMP_GE_OQ));
      const unsigned m = ~static_cast<unsigned>(_mm256_movemask_ps(quiet)) & 0xffu;
      mask[(i - begin) / 8] = static_cast<std::uint8_t>(m);
      any |= m;
    }
    for (std::uint32_t i = whole; i < end; ++i) {
      const std::int32_t j = static_cast<std::int32_t>(i) + nb[i];
      if (!spring_quiet(X[j] - X[i], Y[j] - Y[i], Z[j] - Z[i], L[i], yield)) {
        mask[(i - begin) / 8] |= static_cast<std::uint8_t>(1u << ((i - begin) % 8));
        any = 1;
      }
    }
    std::memcpy(mask_out + kRow * (1 + s), mask, kRow);
  }
  return any != 0;
}
#endif

}  // namespace

bool yield_candidates(const ForceArgs<float>& a, float yield, float anchor_limit, bool springs, std::uint32_t begin,
                      std::uint32_t end, std::uint8_t* mask) {
#if defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES)
  if (avx2_paths_active())
    return yield_candidates_avx2(a, yield, anchor_limit, springs, begin, end, mask);
#endif
  return yield_candidates_scalar(a, yield, anchor_limit, springs, begin, end, mask);
}

bool yield_candidates(const ForceArgs<double>& a, double yield, double anchor_limit, bool springs,
                      std::uint32_t begin, std::uint32_t end, std::uint8_t* mask) {
  return yield_candidates_scalar(a, yield, anchor_limit, springs, begin, end, mask);
}

// --- narrow phase: outcodes ----------------------------------------------------
namespace {

template <class S>
void outcodes_scalar(const S* x, const S* y, const S* z, std::uint32_t begin, std::uint32_t end, const S* lo,
                     const S* hi, std::uint8_t* out) {
  for (std::uint32_t i = begin; i < end; ++i) out[i] = outcode(x[i], y[i], z[i], lo, hi);
}

#if defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES)
__attribute__((target("avx2"))) void outcodes_avx2(const float* x, const float* y, const float* z,
                                                   std::uint32_t begin, std::uint32_t end, const float* lo,
                                                   const float* hi, std::uint8_t* out) {
  const float* const src[3] = {x, y, z};
  const std::uint32_t whole = begin + (end - begin) / 8 * 8;
  for (std::uint32_t i = begin; i < whole; i += 8) {
    __m256i acc = _mm256_setzero_si256();
    for (int ax = 0; ax < 3; ++ax) {
      const __m256 v = _mm256_loadu_ps(src[ax] + i);
      const __m256 below = _mm256_cmp_ps(v, _mm256_set1_ps(lo[ax]), _CMP_LT_OQ);
      const __m256 above = _mm256_cmp_ps(v, _mm256_set1_ps(hi[ax]), _CMP_GT_OQ);
      acc = _mm256_or_si256(acc, _mm256_and_si256(_mm256_castps_si256(below), _mm256_set1_epi32(1 << (2 * ax))));
      acc = _mm256_or_si256(acc,
                            _mm256_and_si256(_mm256_castps_si256(above), _mm256_set1_epi32(2 << (2 * ax))));
    }
    const __m128i w = _mm_packs_epi32(_mm256_castsi256_si128(acc), _mm256_extracti128_si256(acc, 1));
    _mm_storel_epi64(reinterpret_cast<__m128i*>(out + i), _mm_packus_epi16(w, w));
  }
  for (std::uint32_t i = whole; i < end; ++i) out[i] = outcode(x[i], y[i], z[i], lo, hi);
}
#endif

}  // namespace

void outcodes(const float* x, const float* y, const float* z, std::uint32_t begin, std::uint32_t end,
              const float* lo, const float* hi, std::uint8_t* out) {
#if defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES)
  if (avx2_paths_active()) return outcodes_avx2(x, y, z, begin, end, lo, hi, out);
#endif
  outcodes_scalar(x, y, z, begin, end, lo, hi, out);
}

void outcodes(const double* x, const double* y, const double* z, std::uint32_t begin, std::uint32_t end,
              const double* lo, const double* hi, std::uint8_t* out) {
  outcodes_scalar(x, y, z, begin, end, lo, hi, out);
}

const char* active_clone() {
#if defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES) && defined(__clang__)
  return "none (clang)";
#elif defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES)
  return g_has_avx2 ? "avx2" : "default";
#else
  return "none";
#endif
}

}  // namespace sculpt::sim::SCULPT_SIM_KERNEL_NS
