#include "sim/kernels.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

// Build every hot kernel twice, for AVX2 and for plain x86-64, and pick at load
// time (ifunc). -ffp-contract=off (top-level meson.build) keeps the two clones
// from fusing multiply-adds differently. SCULPT_SIM_KERNEL_NS lets a test build
// a second, clone-free copy of this file to compare against.
#if defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES)
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

template <class S, ForceModel M, Velocity V>
[[gnu::always_inline]] inline S forces_impl(const ForceArgs<S>& A, std::uint32_t begin, std::uint32_t end,
                                            std::uint32_t ob, std::uint32_t oe) {
  alignas(64) S fx[kBlock], fy[kBlock], fz[kBlock], pe[kBlock];
  alignas(64) S vx[kBlock], vy[kBlock], vz[kBlock];
  const std::uint32_t cnt = end - begin;
  const S* __restrict X = A.x;
  const S* __restrict Y = A.y;
  const S* __restrict Z = A.z;
  const S* __restrict WX = A.wx;
  const S* __restrict WY = A.wy;
  const S* __restrict WZ = A.wz;
  const S* __restrict RX = A.rx;
  const S* __restrict RY = A.ry;
  const S* __restrict RZ = A.rz;
  const S inv_dt = A.inv_dt, k = A.stiffness, c = A.damping, ka = A.anchor, ca = A.anchor_damping;
  const S quarter_k = S(0.25) * k, half_ka = S(0.5) * ka;
  const S gx = A.gravity_force[0], gy = A.gravity_force[1], gz = A.gravity_force[2];

  for (std::uint32_t i = 0; i < cnt; ++i) {
    const std::uint32_t v = begin + i;
    S ux, uy, uz;
    if constexpr (V == Velocity::backward_difference) {
      ux = (X[v] - WX[v]) * inv_dt;
      uy = (Y[v] - WY[v]) * inv_dt;
      uz = (Z[v] - WZ[v]) * inv_dt;
    } else {
      ux = WX[v];
      uy = WY[v];
      uz = WZ[v];
    }
    vx[i] = ux;
    vy[i] = uy;
    vz[i] = uz;
    const S dx = RX[v] - X[v], dy = RY[v] - Y[v], dz = RZ[v] - Z[v];
    fx[i] = ka * dx - ca * ux + gx;
    fy[i] = ka * dy - ca * uy + gy;
    fz[i] = ka * dz - ca * uz + gz;
    // Gravity's potential relative to rest: −m g·(x − r) = m g·(r − x).
    pe[i] = half_ka * (dx * dx + dy * dy + dz * dz) + (gx * dx + gy * dy + gz * dz);
  }

  for (int s = 0; s < A.slots; ++s) {
    const std::int32_t* __restrict nb = A.nbr + static_cast<std::size_t>(s) * A.stride + begin;
    const S* __restrict L = M == ForceModel::spring ? A.rest_length + static_cast<std::size_t>(s) * A.stride + begin
                                                    : nullptr;
    for (std::uint32_t i = 0; i < cnt; ++i) {
      const std::uint32_t v = begin + i;
      const std::int32_t j = nb[i];
      S ujx, ujy, ujz;
      if constexpr (V == Velocity::backward_difference) {
        ujx = (X[j] - WX[j]) * inv_dt;
        ujy = (Y[j] - WY[j]) * inv_dt;
        ujz = (Z[j] - WZ[j]) * inv_dt;
      } else {
        ujx = WX[j];
        ujy = WY[j];
        ujz = WZ[j];
      }
      S erx = 0, ery = 0, erz = 0, len = 0;
      if constexpr (M == ForceModel::linear) {
        erx = RX[j] - RX[v];
        ery = RY[j] - RY[v];
        erz = RZ[j] - RZ[v];
      } else {
        len = L[i];
      }
      pair_force<S, M>(X[j] - X[v], Y[j] - Y[v], Z[j] - Z[v], ujx - vx[i], ujy - vy[i], ujz - vz[i], erx, ery, erz,
                       len, k, c, quarter_k, fx[i], fy[i], fz[i], pe[i]);
    }
  }

  for (std::uint32_t o = ob; o < oe; ++o) {
    const Overflow<S>& e = A.overflow[o];
    const std::uint32_t v = e.i, i = v - begin;
    const std::int32_t j = e.j;
    S ujx, ujy, ujz;
    if constexpr (V == Velocity::backward_difference) {
      ujx = (X[j] - WX[j]) * inv_dt;
      ujy = (Y[j] - WY[j]) * inv_dt;
      ujz = (Z[j] - WZ[j]) * inv_dt;
    } else {
      ujx = WX[j];
      ujy = WY[j];
      ujz = WZ[j];
    }
    pair_force<S, M>(X[j] - X[v], Y[j] - Y[v], Z[j] - Z[v], ujx - vx[i], ujy - vy[i], ujz - vz[i], RX[j] - RX[v],
                     RY[j] - RY[v], RZ[j] - RZ[v], e.rest_length, k, c, quarter_k, fx[i], fy[i], fz[i], pe[i]);
  }

  const S inv_m = A.inv_mass;
  S* __restrict AX = A.ax;
  S* __restrict AY = A.ay;
  S* __restrict AZ = A.az;
  for (std::uint32_t i = 0; i < cnt; ++i) {
    AX[begin + i] = fx[i] * inv_m;
    AY[begin + i] = fy[i] * inv_m;
    AZ[begin + i] = fz[i] * inv_m;
  }
  return sum8(pe, cnt);
}

template <class S>
[[gnu::always_inline]] inline S dispatch_forces(const ForceArgs<S>& a, ForceModel model, Velocity vel,
                                                std::uint32_t begin, std::uint32_t end, std::uint32_t ob,
                                                std::uint32_t oe) {
  if (model == ForceModel::spring) {
    return vel == Velocity::backward_difference
               ? forces_impl<S, ForceModel::spring, Velocity::backward_difference>(a, begin, end, ob, oe)
               : forces_impl<S, ForceModel::spring, Velocity::stored>(a, begin, end, ob, oe);
  }
  return vel == Velocity::backward_difference
             ? forces_impl<S, ForceModel::linear, Velocity::backward_difference>(a, begin, end, ob, oe)
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
      const S ox = X[i], oy = Y[i], oz = Z[i];
      const S nx = ox + (ox - WX[i]) + AX[i] * dt2;
      const S ny = oy + (oy - WY[i]) + AY[i] * dt2;
      const S nz = oz + (oz - WZ[i]) + AZ[i] * dt2;
      WX[i] = ox;
      WY[i] = oy;
      WZ[i] = oz;
      X[i] = nx;
      Y[i] = ny;
      Z[i] = nz;
      ux = (nx - ox) * inv_dt;
      uy = (ny - oy) * inv_dt;
      uz = (nz - oz) * inv_dt;
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
                       A.ax + begin, A.ay + begin, A.az + begin, A.dt, A.inv_dt, cnt, sp);
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

}  // namespace

SCULPT_CLONES float forces(const ForceArgs<float>& a, ForceModel model, Velocity vel, std::uint32_t begin,
                           std::uint32_t end, std::uint32_t ob, std::uint32_t oe) {
  return dispatch_forces(a, model, vel, begin, end, ob, oe);
}
SCULPT_CLONES double forces(const ForceArgs<double>& a, ForceModel model, Velocity vel, std::uint32_t begin,
                            std::uint32_t end, std::uint32_t ob, std::uint32_t oe) {
  return dispatch_forces(a, model, vel, begin, end, ob, oe);
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

const char* active_clone() {
#if defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES)
  return __builtin_cpu_supports("avx2") ? "avx2" : "default";
#else
  return "none";
#endif
}

}  // namespace sculpt::sim::SCULPT_SIM_KERNEL_NS
