// Every hand-written AVX2 (immintrin) kernel, float only, eight vertices per
// vector. Each performs the portable loop's IEEE operations (kernels_shared.inl)
// in the same order without fused multiply-adds, so the results are the same
// bits; kernels_avx2.hpp says what each entry point stands in for.
// Compiled only for x86-64 with clones on; otherwise stubs (see the #else).
#include "sim/kernels_avx2.hpp"

#if defined(__x86_64__) && !defined(SCULPT_SIM_NO_CLONES)

#include <immintrin.h>

#include <cstddef>
#include <cstdint>
#include <cstring>

#include "sim/kernels_avx2_lanes.inl"
#include "sim/kernels_shared.inl"

namespace sculpt::sim::kernel::avx2 {
namespace {

bool detect_avx2() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2");
}

// --- forces --------------------------------------------------------------------
// The neighbour loop with AVX2 intrinsics, 8 vertices at a time: neighbours
// from the packed records, or (Packed = false: bodies without them, the big
// ones) lane by lane from the arrays at vertex + 16-bit offset, which the
// compiler's own loop (forces_portable) does in more instructions, extracting
// each offset from a vector first. Identical bits either way.
template <ForceModel M, Velocity V, bool Packed, bool Ring = false>
__attribute__((target("avx2"), always_inline)) inline void columns_avx2(const ForceArgs<float>& A, std::uint32_t begin,
                                                                       std::uint32_t cnt, BlockScratch<float>& w) {
  const float k = A.stiffness, c = A.damping, quarter_k = 0.25f * k;
  const __m256 k8 = _mm256_set1_ps(k), c8 = _mm256_set1_ps(c), qk8 = _mm256_set1_ps(quarter_k);
  const __m256 one8 = _mm256_set1_ps(1.0f), tiny8 = _mm256_set1_ps(Tiny<float>::value);
  // Vertex groups outside, columns inside: the accumulators stay in registers
  // and each vertex still sums its springs in column order (same bits).
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
    accumulate_columns8<M>(fetch, nb0 + i, M == ForceModel::spring ? L0 + i : nullptr, stride, A.columns, k8, c8, qk8, one8,
                         tiny8, xi, yi, zi, vxi, vyi, vzi, fx, fy, fz, pe, one8, one8, nullptr);
    store_sums8(w, i, fx, fy, fz, pe);
  }
  // The rest (a body's last block), one vertex at a time.
  for (; i < cnt; ++i) {
    const std::uint32_t v = begin + i;
    for (int s = 0; s < A.columns; ++s) {
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
  columns_avx2<M, V, Packed, Ring>(A, begin, cnt, w);
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

// --- packing -------------------------------------------------------------------

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

// --- the fused pass: forces, integrate, pack -------------------------------------
// A body's last, partial block (or any block with the testing switch
// force_block_pieces): forces_avx2_block + write_acc + integrate + pack_avx2,
// without the acceleration buffer.
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
  integrate_loop<float, I>(In.x + begin, In.y + begin, In.z + begin, In.wx + begin, In.wy + begin, In.wz + begin,
                           w.fx, w.fy, w.fz, In.dt, In.inv_dt, cnt, sp);
  const BlockSums<float> sums = speed_sums(sp, cnt);
  if constexpr (!Ring) pack_avx2<V, M>(A, packed_next + 8 * static_cast<std::size_t>(begin), begin, end);
  return sums;
}

// A whole block (kBlock vertices) in one pass over groups of eight, with the
// state in registers: anchor and own velocity, neighbour columns, integrate,
// speed sums, pack. The same IEEE operations in the same order as
// forces_avx2_block + write_acc + integrate_loop + pack_avx2 (identical bits),
// without the scalar prologue loops, the acceleration round trip and the
// re-reads. Blocks with overflow neighbours keep the forces in the scratch
// until their extras are added (a vertex sums columns first, then extras).
template <ForceModel M, Velocity V, Integrator I, bool Yield = false, bool Ring = false>
__attribute__((target("avx2"))) BlockSums<float> fused_full_block_avx2(const ForceArgs<float>& A,
                                                                       const IntegrateArgs<float>& In,
                                                                       std::uint32_t begin, std::uint32_t ob,
                                                                       std::uint32_t oe, float* packed_next,
                                                                       float& potential,
                                                                       const YieldArgs* ya = nullptr) {
  static_assert(kBlock % 8 == 0);
  static_assert(!Yield || M == ForceModel::spring, "yield marks: spring model only");
  const YieldLanes yl = Yield ? yield_lanes(*ya) : YieldLanes{};
  std::uint8_t* marks = yl.marks;
  const float k = A.stiffness, c = A.damping;
  const __m256 k8 = _mm256_set1_ps(k), c8 = _mm256_set1_ps(c), qk8 = _mm256_set1_ps(0.25f * k);
  const __m256 one8 = _mm256_set1_ps(1.0f), tiny8 = _mm256_set1_ps(Tiny<float>::value);
  const __m256 inv_dt = _mm256_set1_ps(A.inv_dt);
  const Anchor8 anchor = anchor_lanes(A);
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
    own_velocity8<V>(WX + i, WY + i, WZ + i, inv_dt, vx, vy, vz);
    const __m256 rx = _mm256_load_ps(RX + i), ry = _mm256_load_ps(RY + i), rz = _mm256_load_ps(RZ + i);
    const __m256 dx = _mm256_sub_ps(rx, x), dy = _mm256_sub_ps(ry, y), dz = _mm256_sub_ps(rz, z);
    __m256 fx, fy, fz, pe;
    anchor_forces8(anchor, dx, dy, dz, vx, vy, vz, fx, fy, fz, pe);
    if constexpr (Yield) {  // yield_block's anchor test: |x − r| > limit (the same squares, the same sums)
      const __m256 u = _mm256_sqrt_ps(
          _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz)));
      marks[i / 8] = static_cast<std::uint8_t>(_mm256_movemask_ps(_mm256_cmp_ps(u, yl.limit8, _CMP_GT_OQ)));
    }
    __m256 xi = x, yi = y, zi = z;
    if constexpr (M == ForceModel::linear)
      xi = _mm256_sub_ps(x, rx), yi = _mm256_sub_ps(y, ry), zi = _mm256_sub_ps(z, rz);
    accumulate_columns8<M, Yield>(FromRecords<Ring>{P, begin + i, A.ring_mask}, nb0 + i,
                                M == ForceModel::spring ? L0 + i : nullptr, stride, A.columns, k8, c8, qk8,
                                one8, tiny8, xi, yi, zi, vx, vy, vz, fx, fy, fz, pe, yl.up8, yl.down8,
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

// --- clay: which entries of a block might yield -----------------------------------
// Eight vertices at a time; tails go scalar. Neighbours come from the packed
// records when there are any (two 16-byte loads and a transpose per eight, as
// in the force kernel), else lane by lane (gather8, not vgatherdps: slower).
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
  const int columns = springs ? a.columns : 0;
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
  for (int s = 0; s < columns; ++s) {
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

// --- narrow phase: outcodes --------------------------------------------------------
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

}  // namespace

const bool usable = detect_avx2();

float forces(const ForceArgs<float>& a, ForceModel model, Velocity vel, std::uint32_t begin, std::uint32_t end,
             std::uint32_t ob, std::uint32_t oe) {
  if (a.packed && a.ring_mask) return forces_avx2<true, true>(a, model, vel, begin, end, ob, oe);
  return a.packed ? forces_avx2<true>(a, model, vel, begin, end, ob, oe)
                  : forces_avx2<false>(a, model, vel, begin, end, ob, oe);
}

void pack_into(const ForceArgs<float>& A, ForceModel model, Velocity vel, float* packed, std::uint32_t begin,
               std::uint32_t end) {
  const bool bd = vel == Velocity::step, lin = model == ForceModel::linear;
  if (bd && !lin) pack_avx2<Velocity::step, ForceModel::spring>(A, packed, begin, end);
  else if (bd) pack_avx2<Velocity::step, ForceModel::linear>(A, packed, begin, end);
  else if (!lin) pack_avx2<Velocity::stored, ForceModel::spring>(A, packed, begin, end);
  else pack_avx2<Velocity::stored, ForceModel::linear>(A, packed, begin, end);
}

BlockSums<float> step_block(const ForceArgs<float>& a, const IntegrateArgs<float>& in, bool spring,
                            Integrator integrator, bool whole, std::uint32_t begin, std::uint32_t end,
                            std::uint32_t ob, std::uint32_t oe, float* packed_next, float& potential) {
  return a.ring_mask ? fused_dispatch<true>(a, in, spring, integrator, whole, begin, end, ob, oe, nullptr, potential)
                     : fused_dispatch<false>(a, in, spring, integrator, whole, begin, end, ob, oe, packed_next,
                                             potential);
}

BlockSums<float> step_whole_block_marking_yield(const ForceArgs<float>& a, const IntegrateArgs<float>& in,
                                                Integrator integrator, std::uint32_t begin, std::uint32_t ob,
                                                std::uint32_t oe, float* packed_next, float& potential,
                                                const YieldArgs& yield) {
  if (integrator == Integrator::position_verlet)
    return fused_full_block_avx2<ForceModel::spring, Velocity::step, Integrator::position_verlet, true>(
        a, in, begin, ob, oe, packed_next, potential, &yield);
  return fused_full_block_avx2<ForceModel::spring, Velocity::stored, Integrator::symplectic_euler, true>(
      a, in, begin, ob, oe, packed_next, potential, &yield);
}

bool yield_candidates(const ForceArgs<float>& a, float yield, float anchor_limit, bool springs, std::uint32_t begin,
                      std::uint32_t end, std::uint8_t* mask) {
  return yield_candidates_avx2(a, yield, anchor_limit, springs, begin, end, mask);
}

void outcodes(const float* x, const float* y, const float* z, std::uint32_t begin, std::uint32_t end,
              const float* lo, const float* hi, std::uint8_t* out) {
  outcodes_avx2(x, y, z, begin, end, lo, hi, out);
}

}  // namespace sculpt::sim::kernel::avx2

#else  // no AVX2 kernels in this build: usable is false, so nothing calls these.

#include <cstdlib>

namespace sculpt::sim::kernel::avx2 {

const bool usable = false;

float forces(const ForceArgs<float>&, ForceModel, Velocity, std::uint32_t, std::uint32_t, std::uint32_t,
             std::uint32_t) {
  std::abort();
}
void pack_into(const ForceArgs<float>&, ForceModel, Velocity, float*, std::uint32_t, std::uint32_t) { std::abort(); }
BlockSums<float> step_block(const ForceArgs<float>&, const IntegrateArgs<float>&, bool, Integrator, bool,
                            std::uint32_t, std::uint32_t, std::uint32_t, std::uint32_t, float*, float&) {
  std::abort();
}
BlockSums<float> step_whole_block_marking_yield(const ForceArgs<float>&, const IntegrateArgs<float>&, Integrator,
                                                std::uint32_t, std::uint32_t, std::uint32_t, float*, float&,
                                                const YieldArgs&) {
  std::abort();
}
bool yield_candidates(const ForceArgs<float>&, float, float, bool, std::uint32_t, std::uint32_t, std::uint8_t*) {
  std::abort();
}
void outcodes(const float*, const float*, const float*, std::uint32_t, std::uint32_t, const float*, const float*,
              std::uint8_t*) {
  std::abort();
}

}  // namespace sculpt::sim::kernel::avx2

#endif
