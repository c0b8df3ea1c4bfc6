// A scene's simulation: meshes (bodies), tools, one fixed tick at a time.
//
//   World<float> world(settings, /*tool_slots=*/2);
//   world.add_body(mesh, material);           // setup: allocates, may throw
//   world.step(tools);                        // real time: no allocation, no locks, no I/O
//   world.feedback()[t].force;                // to the haptics
//   world.changes();                          // vertex ranges that moved, to the viewers
//
// Deterministic: one thread, fixed iteration order, no reductions whose order
// depends on anything but the data: same scene and tool inputs → same bits.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "sim/body.hpp"
#include "sim/contact.hpp"
#include "sim/stroke_recorder.hpp"
#include "sim/strokes.hpp"
#include "sim/grab.hpp"
#include "sim/stepper.hpp"
#include "sim/tool_track.hpp"
#include "sim/material.hpp"
#include "sim/settings.hpp"
#include "sim/tool.hpp"
#include "sim/triangle_mesh.hpp"

namespace sculpt::sim {

// Vertices [begin, end) of a body, in the body's internal (spatial) order,
// changed this tick; Body::to_original maps them back to the file's order.
struct ChangeRange {
  std::uint32_t body;
  std::uint32_t begin;
  std::uint32_t end;
};

enum class BlowupCause : std::uint8_t { non_finite, energy_growth };

// After each blow-up a body steps with twice the substeps, up to this many times its own.
inline constexpr int kMaxSubstepBoost = 64;
// A state or block image from outside (World::restore_state, block_image_error)
// has its positions within this of the origin (the bound a tool's own
// position is held to, far beyond any scene) and its velocities within this
// many times the guard's speed limit (room for the pushes after its test).
inline constexpr double kStateMaxCoordinate = 1e6;
inline constexpr double kStateSpeedMargin = 4.0;

struct TickStats {
  std::uint64_t vertex_steps = 0;    // vertices integrated × substeps, this tick
  std::uint32_t awake_blocks = 0;    // blocks integrated this tick
  std::uint32_t awake_vertices = 0;
  std::uint32_t candidate_blocks = 0;  // blocks the narrow phase looked at
  std::uint32_t contacts = 0;
  std::uint32_t blowups = 0;         // meshes restored this tick
  std::uint64_t blowups_total = 0;
  // The latest blow-up (valid once blowups_total > 0): which body, and
  // whether a position went non-finite or the energy grew with no input.
  std::uint32_t last_blowup_body = 0;
  BlowupCause last_blowup_cause = BlowupCause::non_finite;
  std::uint32_t ignored_tools = 0;   // tool inputs rejected this tick (non-finite, bad radius)
};

template <class S>
class World {
 public:
  // Throws std::invalid_argument naming the bad setting.
  explicit World(const SimSettings& settings, int tool_slots = 2);

  // Setup (allocates). Throws std::invalid_argument on a bad mesh or material.
  // Returns the body's index.
  std::uint32_t add_body(const TriangleMesh& mesh, const Material& material, const BodyOptions& options = {});

  // One tick of 1/rate_hz. tools[t] drives tool slot t; missing slots are inactive,
  // tools beyond the tool slots are ignored (TickStats::ignored_tools counts them).
  void step(std::span<const Tool> tools);

  // Optional stage timing, for the daemon's stats: with a clock (nanoseconds,
  // any fixed origin; it must not allocate or block) step() adds up the time
  // spent finding and resolving contacts (broadphase + narrow phase), so
  // collision_ns() of the last step can be told from integration. No clock,
  // no cost. Timing only: it changes no result.
  using StageClock = std::uint64_t (*)();
  void set_stage_clock(StageClock clock) { stage_clock_ = clock; }
  std::uint64_t collision_ns() const { return collision_ns_; }

  std::span<const ToolFeedback> feedback() const { return feedback_; }
  const TickStats& stats() const { return stats_; }
  std::span<const ChangeRange> changes() const { return {changes_.data(), change_count_}; }

  std::size_t body_count() const { return bodies_.size(); }
  const Body<S>& body(std::size_t i) const { return bodies_[i]; }
  int substeps(std::size_t i) const;
  // How body i steps (stepper.hpp), decided once in add_body.
  StepPath step_path(std::size_t i) const { return paths_[i]; }
  const SimSettings& settings() const { return settings_; }
  std::uint64_t tick() const { return tick_; }

  // Positions in the mesh's original vertex order (out.size() == vertex count).
  void positions(std::size_t body, std::span<Vec3f> out) const;
  Vec3d position(std::size_t body, std::uint32_t original_index) const;
  // Set a vertex's position and velocity (tests, scripted scenes); wakes it.
  void set_state(std::size_t body, std::uint32_t original_index, const Vec3d& position, const Vec3d& velocity);
  // Wake every block of a body (benchmarks that measure the kernels on a whole mesh).
  void wake_all(std::size_t body);
  // Total energy of a body at the end of the last tick it was active, J.
  double energy(std::size_t body) const { return bodies_[body].energy; }

  // Everything later ticks read of the state earlier ticks wrote, as bytes
  // (allocates); a world built from the same scene and settings continues
  // from them bit for bit. restore_state throws std::invalid_argument naming
  // what does not match (another scene, precision or build) or cannot be
  // (an index out of range, a value not finite or beyond any world, a
  // network or rest shape that is not the scene's), leaving the world as it
  // was: the bytes are untrusted input. Between ticks only. Restoring closes
  // the open strokes.
  std::vector<std::byte> state() const;
  void restore_state(std::span<const std::byte> bytes);

  // Strokes (sim/strokes.hpp, docs/simulation.md): with a sink, the world tells
  // it each body's strokes and hands it the image of every block an open stroke
  // is about to change. nullptr (the default): nothing is recorded, and it
  // costs a branch. Either way the same scene and inputs give the same bits.
  // Setup or between ticks; closes the open strokes first (to the old sink).
  void set_stroke_sink(StrokeSink* sink);
  // Closes every open stroke now (last_tick: tick()), between ticks: before an
  // undo or redo, or a scene swap. A tool still near opens a new one next tick.
  void close_strokes();
  // A block's image (block_image.hpp): the same size for every block of a
  // body (0 for a body without vertices). Throws std::invalid_argument on a
  // body or block that does not exist, or an `out` of another size.
  std::size_t block_image_bytes(std::uint32_t body) const;
  void block_image(std::uint32_t body, std::uint32_t block, std::span<std::byte> out) const;
  // Exchanges block `block` of `body` with `image` (one from block_image or
  // StrokeSink::captured of the same block of a world of the same scene): the
  // world takes the image, the image takes what the world had; swapping again
  // gives both back. The next step lists the block in changes(), even if it
  // sleeps. Between ticks, allocation-free (the real-time thread undoes).
  // Throws std::invalid_argument, changing nothing, on a body or block that
  // does not exist, an image of another size, or a body with an open stroke
  // (close_strokes() first).
  void exchange_block_image(std::uint32_t body, std::uint32_t block, std::span<std::byte> image);
  // exchange_block_image trusts the image's values (it is the real-time
  // thread's); one from outside (a stroke read back from a store) is checked
  // here first: "" when body, block and size fit and every value is one the
  // block can hold (sim/block_image.hpp), else what is wrong.
  std::string block_image_error(std::uint32_t body, std::uint32_t block, std::span<const std::byte> image) const;

  // FNV-1a over the position bits of every body in original order.
  std::uint64_t hash() const;
  std::size_t bytes() const;

 private:
  void read_tools(std::span<const Tool> tools);
  void report_tools();
  void step_body(std::uint32_t bi);
  void find_contacts(std::uint32_t bi);
  Substep<S> begin_tick(std::uint32_t bi);
  void resolve_contacts(Body<S>& b, const Substep<S>& s);
  void judge(std::uint32_t bi, bool finite);
  void settle(Body<S>& b, double energy);
  void log_changes(std::uint32_t bi);
  void read_state(class StateReader& r);
  void check_state(const class StateView& view) const;
  void check_block(const char* what, std::uint32_t body, std::uint32_t block, std::size_t bytes) const;

  SimSettings settings_;
  std::uint32_t tool_slots_;
  std::vector<Body<S>> bodies_;
  std::vector<StepPath> paths_;                       // per body, chosen in add_body
  std::vector<std::unique_ptr<Stepper<S>>> steppers_;  // per body
  std::vector<int> base_substeps_;
  std::vector<std::unique_ptr<StrokeRecorder<S>>> recorders_;  // per body
  StrokeSink* stroke_sink_ = nullptr;
  std::vector<ToolTrack<S>> tracks_;
  std::vector<ToolFeedback> feedback_;
  std::vector<ChangeRange> changes_;
  std::size_t change_count_ = 0;
  // Scratch sized in add_body for the largest body (the step never allocates).
  std::vector<double> potential_;          // per awake block, the last substep's potential energy
  std::vector<std::uint8_t> yield_masks_;  // clay: yield marks per awake block
  AlignedBuffer<S> scratch_;               // accelerations of one block (the fused paths' pieces)
  AlignedBuffer<float> ring_;              // the ring of packed records bodies on the ring path step through in turn
  GrabSprings<S> grabs_;
  NarrowPhase<S> narrow_;
  TickStats stats_;
  std::uint64_t tick_ = 0;
  std::uint64_t blowups_total_ = 0;
  std::uint32_t last_blowup_body_ = 0;
  BlowupCause last_blowup_cause_ = BlowupCause::non_finite;
  StageClock stage_clock_ = nullptr;
  std::uint64_t collision_ns_ = 0;
};

extern template class World<float>;
extern template class World<double>;

}  // namespace sculpt::sim
