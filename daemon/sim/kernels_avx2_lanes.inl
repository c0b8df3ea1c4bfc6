// The eight-lane building blocks of the AVX2 kernels: loads, transposes, one
// spring per lane, the finish of a fused group. Each does the portable code's
// (kernels_shared.inl) operations in its order without fused multiply-adds.
// Included only by kernels_avx2.cpp, inside its one build guard.
#pragma once

#include <immintrin.h>

#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "sim/kernels_shared.inl"

namespace sculpt::sim::kernel::avx2 {
namespace {

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

// a[j[0]], …, a[j[7]] by scalar loads into lanes: faster here than vgatherdps.
__attribute__((target("avx2"), always_inline)) inline __m256 gather8(const float* __restrict a, const std::int32_t* j) {
  return _mm256_setr_ps(a[j[0]], a[j[1]], a[j[2]], a[j[3]], a[j[4]], a[j[5]], a[j[6]], a[j[7]]);
}

// How accumulate_columns8 fetches the eight neighbours of one column row (nb:
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

// The neighbour columns of eight consecutive vertices (nb0 and L0 at the first
// one's column-0 entries), each row's neighbours from `fetch`. Every arithmetic
// step is the one pair_force() does, in the same order, without fused
// multiply-adds: identical bits. Accumulates into f and pe, in column order.
// With Yield (spring model), also marks[s · kBlock/8] = the springs whose
// length is past ±yield of their rest length: yield_block's exact test
// (same length bits, same thresholds), from the length the force needs anyway.
template <ForceModel M, bool Yield = false, class Fetch>
__attribute__((target("avx2"), always_inline)) inline void accumulate_columns8(
    const Fetch& fetch, const std::int16_t* __restrict nb0, const float* __restrict L0, std::size_t stride,
    int columns, __m256 k8, __m256 c8, __m256 qk8, __m256 one8, __m256 tiny8, __m256 xi, __m256 yi, __m256 zi,
    __m256 vxi, __m256 vyi, __m256 vzi, __m256& fx, __m256& fy, __m256& fz, __m256& pe, __m256 up8, __m256 down8,
    std::uint8_t* marks) {
  for (int s = 0; s < columns; ++s) {
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

// Eight vertices' own velocities from the w arrays (at the first one): w · 1/dt
// for position Verlet's steps, else w itself.
template <Velocity V>
__attribute__((target("avx2"), always_inline)) inline void own_velocity8(const float* __restrict WX,
                                                                           const float* __restrict WY,
                                                                           const float* __restrict WZ, __m256 inv_dt,
                                                                           __m256& vx, __m256& vy, __m256& vz) {
  if constexpr (V == Velocity::step) {
    vx = _mm256_mul_ps(_mm256_load_ps(WX), inv_dt);
    vy = _mm256_mul_ps(_mm256_load_ps(WY), inv_dt);
    vz = _mm256_mul_ps(_mm256_load_ps(WZ), inv_dt);
  } else {
    vx = _mm256_load_ps(WX), vy = _mm256_load_ps(WY), vz = _mm256_load_ps(WZ);
  }
}

// Anchor, its damper and gravity on eight vertices: init_block's operations in
// its order. d = r − x; starts the forces f and the energy pe.
struct Anchor8 {
  __m256 ka, ca, half_ka, gx, gy, gz;
};
__attribute__((target("avx2"), always_inline)) inline Anchor8 anchor_lanes(const ForceArgs<float>& A) {
  return {_mm256_set1_ps(A.anchor),           _mm256_set1_ps(A.anchor_damping),   _mm256_set1_ps(0.5f * A.anchor),
          _mm256_set1_ps(A.gravity_force[0]), _mm256_set1_ps(A.gravity_force[1]), _mm256_set1_ps(A.gravity_force[2])};
}
__attribute__((target("avx2"), always_inline)) inline void anchor_forces8(const Anchor8& an, __m256 dx, __m256 dy,
                                                                            __m256 dz, __m256 vx, __m256 vy,
                                                                            __m256 vz, __m256& fx, __m256& fy,
                                                                            __m256& fz, __m256& pe) {
  fx = _mm256_add_ps(_mm256_sub_ps(_mm256_mul_ps(an.ka, dx), _mm256_mul_ps(an.ca, vx)), an.gx);
  fy = _mm256_add_ps(_mm256_sub_ps(_mm256_mul_ps(an.ka, dy), _mm256_mul_ps(an.ca, vy)), an.gy);
  fz = _mm256_add_ps(_mm256_sub_ps(_mm256_mul_ps(an.ka, dz), _mm256_mul_ps(an.ca, vz)), an.gz);
  pe = _mm256_add_ps(
      _mm256_mul_ps(an.half_ka, _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)),
                                              _mm256_mul_ps(dz, dz))),
      _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(an.gx, dx), _mm256_mul_ps(an.gy, dy)), _mm256_mul_ps(an.gz, dz)));
}

// Clay's thresholds in lanes, for the marks the fused pass makes: strain past
// ±yield (len > rest·up8 or < rest·down8), anchor displacement past limit8.
struct YieldLanes {
  __m256 up8, down8, limit8;
  std::uint8_t* marks;  // YieldArgs::mask
};
__attribute__((target("avx2"), always_inline)) inline YieldLanes yield_lanes(const YieldArgs& y) {
  return {_mm256_set1_ps(1.0f + y.yield), _mm256_set1_ps(1.0f - y.yield), _mm256_set1_ps(y.anchor_limit), y.mask};
}

// Integrates eight vertices of a block from their forces and packs them into
// packed_next (the tail of the fused pass on a whole block).
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

}  // namespace
}  // namespace sculpt::sim::kernel::avx2
