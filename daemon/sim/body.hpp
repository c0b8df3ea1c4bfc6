// One mesh as a spring network, laid out for the kernels: vertices reordered
// along a Morton curve (spatially compact blocks of kernel::kBlock vertices),
// structure of arrays, 64-byte aligned, neighbours in a column-major padded ELL
// table with an overflow list. Everything is sized at construction; stepping
// (in World) never allocates.
#pragma once

#include <array>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "sim/aligned_buffer.hpp"
#include "sim/kernels.hpp"
#include "sim/material.hpp"
#include "sim/triangle_mesh.hpp"

namespace sculpt::sim {

template <class S>
class StrokeRecorder;  // sim/stroke_recorder.hpp

// The double buffer of packed neighbour records (float only, 64 bytes per
// vertex): by_size gives it to clay bodies up to 65 536 vertices; elastic
// bodies step through the ring of records instead (BodyOptions::ring).
// docs/simulation.md has the measurements.
enum class PackedRecords { by_size, always, never };

struct BodyOptions {
  std::vector<std::uint32_t> pinned;  // original vertex indices held at their rest position
  int max_grabbed = 4096;             // per tool: vertices one grab can hold (preallocated)
  PackedRecords packed = PackedRecords::by_size;
  // Elastic float bodies without packed records step through the ring of
  // packed records (kernel::kRingBlocks) where World runs the AVX2 kernels and
  // a one-pass integrator; false: they gather neighbours from the arrays
  // instead, on the arrays path (benchmarks compare the two).
  bool ring = true;
};

struct BlockTriangle {
  std::uint16_t v[3];  // vertex − Body::begin_of(owning block)
};

template <class S>
struct Pinned {
  std::uint32_t i;  // internal index
  S x, y, z;
};

template <class S>
struct Grab {
  struct NoGap {};
  std::uint32_t i;     // internal index
  // Double aligns ox to 8 bytes. A named gap, zero, where padding would take
  // whatever bytes a store left in it: World::state() copies grabs whole.
  [[no_unique_address]] std::conditional_t<sizeof(S) == 8, std::uint32_t, NoGap> gap{};
  S ox, oy, oz;        // offset from the tool centre at the moment of the grab
};
static_assert(sizeof(Grab<float>) == 16 && sizeof(Grab<double>) == 32);

template <class S>
struct BlockState {
  std::array<S, 3> lo{}, hi{};  // exact box of the block's vertices at the last refit
  S grow = 0;                   // how far any vertex may have moved since that refit
  S reach = 0;                  // longest rest edge of the block's triangles ×1.5: boxes grown by it cover them
  double energy = 0;            // kinetic + potential at the end of the last tick it was awake
  std::uint32_t max_speed2_bits = 0;  // this tick (float bits of |v|² max, as a monotone key)
  int quiet_ticks = 0;
  bool awake = false;
  bool touched = false;   // a tool box reached it this tick (or it holds a grabbed vertex)
  bool changed = false;   // integrated or pushed this tick
  bool dirty = false;     // changed since the last good-state checkpoint
  bool accel_current = false;  // ax..az hold the forces of the present state (velocity Verlet's opening kick needs them)
  bool grabbed = false;   // holds a grabbed vertex (set and cleared within one substep of step_body)
};

template <class S>
struct CheckpointGrid {
  std::array<S, 3> lo{}, step{};  // coordinate = lo + q · step, q in [0, 65535]
};

// Per tool and body: candidate blocks this tick and the vertices a grab holds.
template <class S>
struct ToolContact {
  std::vector<std::uint32_t> candidates;  // capacity = blocks
  std::uint32_t candidate_count = 0;
  std::vector<Grab<S>> grabs;             // capacity = BodyOptions::max_grabbed; sorted by vertex
  std::uint32_t grab_count = 0;
  bool grabbing = false;
};

// A body's data, split by who touches it. Body (below) holds all of them;
// functions take the part they need.

// The memory the per-vertex arrays of big bodies (kArenaMinVertices and up)
// live in (see PageArena). The first base of Body: it outlives every array.
struct BodyMemory {
  PageArena arena;
};

// The spring network and mesh, built by make_body and read by the kernels
// and the narrow phase; only clay's yield writes it (rest lengths).
template <class S>
struct BodyNetwork {
  std::uint32_t n = 0;         // vertices
  std::uint32_t blocks = 0;    // ceil(n / kBlock)
  std::uint32_t springs = 0;   // unique edges with two distinct ends
  int columns = 0;               // ELL width
  int max_degree = 0;
  S mean_edge = 0;             // mean rest edge length (clay yield scale)
  double extent = 0;           // rest bounding-box diagonal
  std::vector<std::uint32_t> to_original;  // internal → original vertex index
  std::vector<std::uint32_t> to_internal;  // original → internal
  // Column s of vertex i: neighbour − i, column-major, columns × n. Springs whose
  // ends lie more than kernel::kRingReach blocks apart go to the overflow list.
  // (So do a high-degree vertex's springs past the ELL width.)
  AlignedBuffer<std::int16_t> nbr;
  AlignedBuffer<S> rest_length;  // columns × n (spring model only)
  std::vector<kernel::Overflow<S>> overflow;
  std::vector<std::uint32_t> overflow_begin;  // blocks + 1
  // Triangles, grouped by owning block (the block of their lowest vertex), as
  // their vertices' offsets from the block's first vertex: 6 bytes instead of
  // 12. The few that span farther (seams of the Morton order) stay whole.
  std::vector<BlockTriangle> triangles;
  std::vector<std::uint32_t> triangle_begin;      // blocks + 1
  std::vector<Triangle> far_triangles;            // internal indices
  std::vector<std::uint32_t> far_triangle_begin;  // blocks + 1
  std::vector<Pinned<S>> pinned;                  // sorted by index
  std::vector<std::uint32_t> pinned_begin;        // blocks + 1
  std::vector<std::uint32_t> block_neighbour_begin, block_neighbours;  // CSR of blocks sharing a spring

  std::uint32_t begin_of(std::uint32_t b) const { return b * kernel::kBlock; }
  std::uint32_t end_of(std::uint32_t b) const { return std::min(n, (b + 1) * kernel::kBlock); }
  // Block blk's triangles as internal indices: the near ones in build order, then the far ones.
  template <class F>
  [[gnu::always_inline]] void for_each_triangle(std::uint32_t blk, F&& f) const {
    const std::uint32_t base = begin_of(blk);
    for (std::uint32_t t = triangle_begin[blk]; t < triangle_begin[blk + 1]; ++t)
      f(Triangle{base + triangles[t].v[0], base + triangles[t].v[1], base + triangles[t].v[2]});
    for (std::uint32_t t = far_triangle_begin[blk]; t < far_triangle_begin[blk + 1]; ++t) f(far_triangles[t]);
  }
};

// The state the step advances, the narrow phase pushes and the guard restores.
template <class S>
struct BodyState {
  kernel::Velocity velocity = kernel::Velocity::step;  // what wx..wz hold (sim/motion.hpp); World sets it
  AlignedBuffer<S> x, y, z;     // positions
  AlignedBuffer<S> wx, wy, wz;  // velocities, as `velocity` says: the last step x − x_prev, or v
  AlignedBuffer<S> rx, ry, rz;  // rest positions (yield in clay)
  // Accelerations between the force and integrate passes, for bodies on the
  // arrays path only (sim/stepper.hpp); the fused paths keep them in registers.
  AlignedBuffer<S> ax, ay, az;
};

// Packed copies of the state for the fused kernels: the records path's
// double buffer, and the ring path's bookkeeping. Touched by the steppers
// only, and kept current by sim/motion.hpp's sync_records.
template <class S>
struct BodyRecords {
  // Float: {x,y,z,0,vx,vy,vz,0} per vertex (linear model: x − r), double
  // buffered so a block can be integrated right after its forces while later
  // blocks still read the old state from the other buffer.
  AlignedBuffer<S> packed[2];
  int packed_cur = 0;
  // The ring (kernel::ForceArgs::ring_mask): the vertices that overflow
  // springs reach from beyond kRingReach blocks (Overflow::far), grouped by
  // block, sorted; their records of the substep's start, saved when their
  // block is packed into the ring; and per block the ring_epoch (one per
  // substep) it was last packed in.
  std::vector<std::uint32_t> far_vertices;
  std::vector<std::uint32_t> far_vertex_begin;  // blocks + 1
  AlignedBuffer<S> far_records;                 // 8 per far vertex
  std::vector<std::uint64_t> ring_stamp;        // blocks
  std::uint64_t ring_epoch = 0;
  // Its ring's size, min(kRingBlocks, blocks rounded up to 2^k); 0: the body
  // never takes the ring (and has none of the above).
  std::uint32_t ring_blocks = 0;
};

// Blocks as the broadphase and the sleeping see them, and each tool's
// contact with the body.
template <class S>
struct BodyBlocks {
  std::vector<BlockState<S>> block;
  std::vector<std::uint32_t> awake_list;  // capacity = blocks
  std::uint32_t awake_count = 0;          // this tick's awake list
  std::uint32_t awake_blocks = 0;         // blocks awake now
  std::array<S, 3> lo{}, hi{};            // union of block boxes (grown), for the mesh-level broadphase
  std::vector<ToolContact<S>> tools;      // one per tool slot of the world
  // Strokes (sim/stroke_recorder.hpp): World's recorder of this body's strokes, and
  // per block whether it may change without a capture first; null while no
  // stroke records (then will_change, sim/stroke_hook.hpp, is one test).
  StrokeRecorder<S>* strokes = nullptr;
  const std::uint8_t* stroke_done = nullptr;
};

// The blow-up guard: the last good state and the energy bookkeeping.
template <class S>
struct BodyGuard {
  // Last good positions, 16 bits per coordinate on a grid over the block's
  // box at the checkpoint: a restore lands within 1/131070 of that box of the
  // saved state, in half the bytes of a copy.
  AlignedBuffer<std::uint16_t> sx, sy, sz;
  std::vector<CheckpointGrid<S>> checkpoint_grid;  // per block
  AlignedBuffer<S> srx, sry, srz, slen;        // clay only: last good rest shape
  double energy = 0;        // last measured total energy, J
  double energy_ref = 0;    // the most energy tool input has put in since the mesh last slept
  double energy_floor = 0;  // noise floor of the energy test
  double speed_limit = 0;   // m/s: a vertex faster than this is divergence (set by World)
  std::uint64_t blowups = 0;
  int boost = 1;            // substep multiplier after a blow-up
  int checkpoint_age = 0;
  bool external_input = false;  // set_state() touched it since the last tick
};

template <class S>
struct Body : BodyMemory, BodyNetwork<S>, BodyState<S>, BodyRecords<S>, BodyBlocks<S>, BodyGuard<S> {
  Material material;
  bool plastic = false;

  std::size_t bytes() const;  // everything this body owns
  // The arrays the kernels read: state, rest shape, springs and the current
  // packed records (float bodies that have them). Material constants and
  // outputs are the caller's.
  kernel::ForceArgs<S> network_args() const;
  // The guard's checkpoint: save block blk's positions (false, keeping the
  // older checkpoint, if any is not finite); the saved position of vertex i.
  bool save_positions(std::uint32_t blk);
  std::array<S, 3> saved_position(std::uint32_t i) const;
};

// From this size a body's per-vertex arrays (~3 MB and up) live in a huge-page
// arena: small ones fit the TLB's reach anyway, and would round up to 2 MiB.
inline constexpr std::uint32_t kArenaMinVertices = 32768;

// Builds the network. Throws std::invalid_argument naming the bad input
// (out-of-range triangle index, non-finite position, bad material...).
template <class S>
Body<S> make_body(const TriangleMesh& mesh, const Material& material, const BodyOptions& options, int tool_slots);

extern template Body<float> make_body(const TriangleMesh&, const Material&, const BodyOptions&, int);
extern template Body<double> make_body(const TriangleMesh&, const Material&, const BodyOptions&, int);

}  // namespace sculpt::sim
