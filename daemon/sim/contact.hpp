// Tools against one body: the broadphase (which blocks a tool's swept box may
// reach, and what a new grab takes hold of) and the narrow phase (push every
// triangle and vertex the tool would pass or end inside out of it, and add the
// reaction to the tool's force).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "sim/body.hpp"
#include "sim/geometry.hpp"
#include "sim/tool_track.hpp"

namespace sculpt::sim {

// Tool t's candidate blocks of b this tick (they are woken and marked
// touched), and the vertices a grab pressed this tick holds. Returns how
// many candidate blocks it found.
template <class S>
std::uint32_t find_candidates(Body<S>& b, std::uint32_t t, const ToolTrack<S>& tr);

template <class S>
class NarrowPhase {
 public:
  // Sized for the largest body (setup: allocates).
  void reserve(std::uint32_t vertices, std::uint32_t blocks);
  // Tool t through b over [alpha0, alpha1] of the tick, in sweeps of at most
  // half a radius, the substep being dts long.
  void resolve(Body<S>& b, std::uint32_t t, ToolTrack<S>& tr, double alpha0, double alpha1, S dts);
  std::size_t bytes() const { return code_.capacity() + stamp_.capacity() * sizeof(std::uint32_t); }

 private:
  struct Sweep;
  void code_candidates(const Body<S>& b, const ToolContact<S>& tc, const Sweep& sw);
  std::uint32_t push_triangles(Body<S>& b, const ToolContact<S>& tc, const Sweep& sw, ToolTrack<S>& tr);
  std::uint32_t push_vertices(Body<S>& b, const ToolContact<S>& tc, const Sweep& sw, ToolTrack<S>& tr);

  // Per vertex, which faces of the sweep's tool box it lies beyond; valid for
  // a block whose stamp equals the epoch (one epoch per sweep).
  std::vector<std::uint8_t> code_;
  std::vector<std::uint32_t> stamp_;
  std::uint32_t epoch_ = 0;
};

// Move vertex i by delta out of a tool whose surface normal there is normal
// and whose speed along it is tool_normal_speed; the reaction goes to tr.
template <class S>
void push_vertex(Body<S>& b, std::uint32_t i, const std::array<S, 3>& delta, const std::array<S, 3>& normal,
                 S tool_normal_speed, S dts, ToolTrack<S>& tr);

}  // namespace sculpt::sim
