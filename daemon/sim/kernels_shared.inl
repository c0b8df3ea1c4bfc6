// The loop bodies the portable kernels (kernels_portable.cpp and friends) and
// the AVX2 kernels (kernels_avx2.cpp) share, written once so that both perform
// the same IEEE operations in the same order: identical bits.
// Included by the kernel .cpp files only. The anonymous namespace gives every
// including file its own copy, like C's static inline.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <type_traits>

#include "sim/kernels.hpp"

namespace sculpt::sim::kernel {
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
// Shared by the vectorised column loop and the scalar overflow loop so both round alike.
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

// The force pass on one block, in pieces, so the AVX2 kernels can swap in
// their own neighbour loop and share everything else (same operations, same
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
      // of two nearby positions, so float keeps its digits.
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

// The sums integrate() returns from the squared speeds sp[0 .. cnt).
template <class S>
[[gnu::always_inline]] inline BlockSums<S> speed_sums(const S* sp, std::uint32_t cnt) {
  alignas(64) Bits<S> bits[kBlock];
  std::memcpy(bits, sp, sizeof(S) * cnt);
  Bits<S> m = 0;
  for (std::uint32_t i = 0; i < cnt; ++i) m = bits[i] > m ? bits[i] : m;
  return {sum8(sp, cnt), m};
}

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


// Clay: squared lengths against thresholds pulled in by a relative 1e-4 (far
// more than the rounding of a square, a product and a sqrt), so an entry left
// unmarked is one the exact test (sqrt, compare) would leave alone: the exact
// test then runs only on marked entries and the results are the same bits.
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

}  // namespace
}  // namespace sculpt::sim::kernel
