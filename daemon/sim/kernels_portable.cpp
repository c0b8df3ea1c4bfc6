// The portable kernels: element-wise loops that GCC builds twice, for AVX2 and
// for plain x86-64, picking one at load time (ifunc). -ffp-contract=off
// (top-level meson.build) keeps the two clones from fusing multiply-adds
// differently. Float bodies on an AVX2 CPU take the hand-written kernels
// (kernels_avx2.cpp) instead; forces() chooses.
//
// GCC only: clang 14 compiles an externally visible target_clones function as
// the AVX2 clone alone (no default clone, no resolver), so a CPU without AVX2
// (qemu's default model in the VM suite, older hosts) dies of SIGILL. Under
// clang the portable kernels are built once for plain x86-64; the hand-written
// AVX2 kernels are still chosen at run time from __builtin_cpu_supports.
#include <cstdint>

#include "sim/kernels.hpp"
#include "sim/kernels_avx2.hpp"
#include "sim/kernels_shared.inl"

#if defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES) && !defined(__clang__)
#define SCULPT_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define SCULPT_CLONES
#endif

namespace sculpt::sim::kernel {
namespace {

// Ring: neighbours from the ring of packed records (a.ring_mask), which hold
// what the arrays would give (x or u = x − r, w·1/dt): the same bits.
template <class S, ForceModel M, Velocity V, bool Ring = false>
[[gnu::always_inline]] inline void columns_generic(const ForceArgs<S>& A, std::uint32_t begin, std::uint32_t cnt,
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
  for (int s = 0; s < A.columns; ++s) {
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

template <class S, ForceModel M, Velocity V, bool Ring = false>
[[gnu::always_inline]] inline S forces_impl(const ForceArgs<S>& A, std::uint32_t begin, std::uint32_t end,
                                            std::uint32_t ob, std::uint32_t oe) {
  BlockScratch<S> w;
  const std::uint32_t cnt = end - begin;
  init_block<S, V>(A, begin, cnt, w);
  columns_generic<S, M, V, Ring>(A, begin, cnt, w);
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

template <class S, Integrator I>
[[gnu::always_inline]] inline BlockSums<S> integrate_impl(const IntegrateArgs<S>& A, std::uint32_t begin,
                                                          std::uint32_t end) {
  alignas(64) S sp[kBlock];
  const std::uint32_t cnt = end - begin;
  integrate_loop<S, I>(A.x + begin, A.y + begin, A.z + begin, A.wx + begin, A.wy + begin, A.wz + begin,
                       A.ax + (begin - A.acc_origin), A.ay + (begin - A.acc_origin), A.az + (begin - A.acc_origin),
                       A.dt, A.inv_dt, cnt, sp);
  return speed_sums(sp, cnt);
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

}  // namespace

float forces(const ForceArgs<float>& a, ForceModel model, Velocity vel, std::uint32_t begin, std::uint32_t end,
             std::uint32_t ob, std::uint32_t oe) {
  if (avx2_paths_active()) return avx2::forces(a, model, vel, begin, end, ob, oe);
  return forces_portable(a, model, vel, begin, end, ob, oe);
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
#if defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES) && defined(__clang__)
  return "none (clang)";
#elif defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES)
  return avx2::usable ? "avx2" : "default";
#else
  return "none";
#endif
}

}  // namespace sculpt::sim::kernel
