// The hot loops of a substep, over one block of consecutive (spatially
// ordered) vertices: gather the spring forces by vertex (no scatter, so no
// write conflicts and a fixed summation order), then integrate. Structure of
// arrays, neighbours in a column-major padded ELL table (column s of vertex i is
// i + nbr[s·stride + i]; padding points at i itself and has rest length 0, which
// gives exactly zero force), rare high-degree extras in an overflow list.
// Every loop is element-wise, so the AVX2 clone and the baseline x86-64 clone
// perform the same IEEE operations in the same order: bit-identical results.
#pragma once

#include <cstdint>

#include "sim/material.hpp"
#include "sim/settings.hpp"

namespace sculpt::sim::kernel {

// Vertices per block: the unit of sleeping, broadphase and change logging.
inline constexpr std::uint32_t kBlock = 128;

// The ring of packed records (elastic float bodies, AVX2): block c's
// records sit at ring block c mod kRingBlocks (fewer for a small body) while
// the blocks within kRingReach of it step. A spring whose ends lie farther apart in blocks is
// never in an ELL column (every body, so every path sums the same springs in
// the same order); it goes to the overflow list, and the ring reads its far
// end from Body::far_records. docs/simulation.md has the measurements.
inline constexpr std::uint32_t kRingBlocks = 64;
inline constexpr std::uint32_t kRingReach = kRingBlocks / 2 - 1;
// Overflow::far of a spring within kRingReach blocks, and of one whose far
// end j lies ahead (its block steps after i's, so j's arrays still hold the
// substep's start when i reads it).
inline constexpr std::uint32_t kNotFar = 0xffffffffu;
inline constexpr std::uint32_t kFarAhead = 0xfffffffeu;

template <class S>
struct Overflow {
  std::uint32_t i;  // the vertex whose row this extra neighbour belongs to
  std::int32_t j;   // the neighbour
  S rest_length;
  // For the ring: kNotFar, kFarAhead, or (j more than kRingReach blocks
  // behind i) j's entry in Body::far_vertices.
  std::uint32_t far = kNotFar;
};

// What the w arrays hold: position Verlet keeps its last step d = x − x_prev
// (velocity d/dt); the other integrators keep the velocity itself.
enum class Velocity { step, stored };

template <class S>
struct ForceArgs {
  const S *x, *y, *z;     // positions
  const S *wx, *wy, *wz;  // last steps or velocities (see Velocity)
  const S *rx, *ry, *rz;  // rest positions
  const std::int16_t* nbr;  // neighbour − vertex
  const S* rest_length;   // ELL rest lengths (spring model), same layout as nbr
  std::uint32_t stride;
  int columns;
  const Overflow<S>* overflow;  // sorted by i
  S stiffness, damping, anchor, anchor_damping;
  S inv_mass, inv_dt;
  S gravity_force[3];     // m·g, or 0
  S *ax, *ay, *az;        // out: accelerations, ax[i − acc_origin] for vertex i
  std::uint32_t acc_origin = 0;  // 0 for a whole body's arrays; a block's first vertex for the scratch
  // Optional (float): per vertex {x, y, z, 0, vx, vy, vz, 0} (linear model: u = x − r), 32-byte
  // aligned, kept current by pack(). Lets the AVX2 path fetch a neighbour with
  // two 16-byte loads instead of six scalar gathers. Same results, bit for bit.
  const S* packed = nullptr;
  // Optional (float): packed is a ring of Body::ring_blocks blocks (vertex i's
  // record at 8·(i & ring_mask)), holding the state the step started from for every
  // block within kRingReach of the one stepping. A far spring's end j reads
  // its step-start state from far_records[8·far] once j's block has been
  // packed this substep (ring_stamp[block] == ring_epoch: it may have moved
  // since), else (and always for kFarAhead) from the arrays (it has not moved).
  std::uint32_t ring_mask = 0;  // 0: packed covers the whole body
  const std::uint64_t* ring_stamp = nullptr;
  std::uint64_t ring_epoch = 0;
  const S* far_records = nullptr;
};

template <class S>
struct IntegrateArgs {
  S *x, *y, *z;
  S *wx, *wy, *wz;
  const S *ax, *ay, *az;  // ax[i − acc_origin] for vertex i (vv_open: origin 0)
  S dt, inv_dt;
  std::uint32_t acc_origin = 0;
};

template <class S>
struct BlockSums {
  S sum_speed2 = 0;                   // Σ|v|² over the block
  std::uint64_t max_speed2_bits = 0;  // bit pattern of max |v|²: NaN and inf compare above every finite value
};

// Accelerations of vertices [begin, end) (at most kBlock of them) and their
// overflow entries [ob, oe); returns the block's potential energy (springs
// counted half per end, anchor, gravity relative to rest).
float forces(const ForceArgs<float>& a, ForceModel model, Velocity vel, std::uint32_t begin, std::uint32_t end,
             std::uint32_t ob, std::uint32_t oe);
double forces(const ForceArgs<double>& a, ForceModel model, Velocity vel, std::uint32_t begin, std::uint32_t end,
              std::uint32_t ob, std::uint32_t oe);

// One step of the integrator on [begin, end). For velocity Verlet this is the
// closing half kick; vv_open does the opening half kick and drift.
BlockSums<float> integrate(const IntegrateArgs<float>& a, Integrator integrator, std::uint32_t begin,
                           std::uint32_t end);
BlockSums<double> integrate(const IntegrateArgs<double>& a, Integrator integrator, std::uint32_t begin,
                            std::uint32_t end);
void vv_open(const IntegrateArgs<float>& a, std::uint32_t begin, std::uint32_t end);
void vv_open(const IntegrateArgs<double>& a, std::uint32_t begin, std::uint32_t end);

// Refresh packed[8i .. 8i+7] for vertices [begin, end) from x, w (and r: the
// linear model packs the displacement u = p − r, all it needs of a neighbour).
void pack(const ForceArgs<float>& a, ForceModel model, Velocity vel, float* packed, std::uint32_t begin,
          std::uint32_t end);
// The same records into out[8(i − begin) .. 8(i − begin) + 7] (a ring block).
void pack_into(const ForceArgs<float>& a, ForceModel model, Velocity vel, float* out, std::uint32_t begin,
               std::uint32_t end);

// The fused pass for one block (float, position Verlet or symplectic Euler,
// AVX2 path): forces with neighbours from a.packed, integrate in place, write
// the block's new state into packed_next. Same bits as forces() + integrate()
// + pack() when a.inv_dt == in.inv_dt (World passes 1/dt to both, so the
// packed velocities are the integrator's own); skips the acceleration buffer.
// With a ring (a.ring_mask), packed_next is null: the ring already holds the
// state the step started from, and nothing is packed after the move.
// A whole block (kBlock vertices) goes through in one pass of eight-vertex
// groups whose state stays in registers from the anchor to the packed record.
//
// Clay (spring model): with `yield`, also marks in yield->mask (the layout of
// yield_candidates) the entries of the state the step starts from that might
// yield. A whole block gets them from the lengths its forces compute anyway
// (exact tests, no second pass over the neighbours); a partial block from
// yield_candidates. The caller applies the yields afterwards.
struct YieldArgs {
  std::uint8_t* mask;  // (1 + columns) · kBlock/8 bytes
  float yield, anchor_limit;
};
BlockSums<float> step_block_fused(const ForceArgs<float>& a, const IntegrateArgs<float>& in, ForceModel model,
                                  Integrator integrator, std::uint32_t begin, std::uint32_t end, std::uint32_t ob,
                                  std::uint32_t oe, float* packed_next, float& potential,
                                  const YieldArgs* yield = nullptr);

// Clay: marks the entries of block [begin, end) (≤ kBlock vertices) that might
// yield, conservatively (squared lengths, a relative margin of 1e-4): one bit
// per vertex, kBlock/8 bytes per row; row 0 the anchors (|x − r| near or past
// anchor_limit), row 1 + s column s's springs (strain near or past ±yield; only
// with `springs`). Uses x, y, z, rx, ry, rz, nbr, rest_length, stride, columns,
// and packed (spring model: neighbours' positions from the current packed
// records, which must match x, y, z; or null).
// An unmarked entry is one the exact test would leave alone. Returns whether any
// bit is set.
bool yield_candidates(const ForceArgs<float>& a, float yield, float anchor_limit, bool springs, std::uint32_t begin,
                      std::uint32_t end, std::uint8_t* mask);
bool yield_candidates(const ForceArgs<double>& a, double yield, double anchor_limit, bool springs,
                      std::uint32_t begin, std::uint32_t end, std::uint8_t* mask);

// Narrow phase: a vertex's outcode has one bit per face of the box
// [lo, hi] that it lies strictly beyond (x < lo[0]: bit 0, x > hi[0]: 1,
// y: 2 and 3, z: 4 and 5; NaN: none). Three vertices whose codes share a bit
// bound a triangle whose box misses [lo, hi].
template <class S>
[[gnu::always_inline]] inline std::uint8_t outcode(S x, S y, S z, const S* lo, const S* hi) {
  return static_cast<std::uint8_t>((x < lo[0]) | (x > hi[0]) << 1 | (y < lo[1]) << 2 | (y > hi[1]) << 3 |
                                   (z < lo[2]) << 4 | (z > hi[2]) << 5);
}
// out[i] = outcode of vertex i for i in [begin, end) (eight at a time on AVX2).
void outcodes(const float* x, const float* y, const float* z, std::uint32_t begin, std::uint32_t end,
              const float* lo, const float* hi, std::uint8_t* out);
void outcodes(const double* x, const double* y, const double* z, std::uint32_t begin, std::uint32_t end,
              const double* lo, const double* hi, std::uint8_t* out);

// Whether the hand-written AVX2 paths run (AVX2 CPU, not switched off by
// kernel_testing.hpp): the fused pass and forces() from packed records or lane
// by lane from the arrays.
bool avx2_paths_active();

// Which clone the CPU runs ("avx2" or "default"), for the benchmark report.
const char* active_clone();

}  // namespace sculpt::sim::kernel
