// Grab springs: each vertex a grab holds follows its tool through a spring of
// the material's grab_stiffness, and the tool feels the pull back. Both sides
// read the vertex's x before its block moves this substep (the tool side
// before any block moves, the vertex side right after its block's forces), so
// they see the same bits without a per-grab buffer.
#pragma once

#include <cstdint>
#include <vector>

#include "sim/body.hpp"
#include "sim/geometry.hpp"
#include "sim/tool_track.hpp"

namespace sculpt::sim {

template <class S>
class GrabSprings {
 public:
  explicit GrabSprings(std::uint32_t tool_slots) : centre_(tool_slots), track_(tool_slots) {}

  // This substep of body b: the tools holding it and where they are.
  // Allocates nothing.
  void begin(Body<S>& b, std::span<ToolTrack<S>> tracks, double alpha0, int substeps);
  bool any() const { return any_; }
  // The pull on every holding tool (a tick average over the substeps).
  void pull_tools();
  // Their accelerations on the vertices of block blk into a's outputs.
  void accelerate(std::uint32_t blk, kernel::ForceArgs<S>& a) const;
  // Flag the blocks holding grabbed vertices (they step in pieces: the grab
  // springs go between their forces and their integration), or clear them.
  void mark_blocks(bool on);

 private:
  geometry::V3<S> force(const geometry::V3<S>& c, const Grab<S>& g) const {
    return {stiffness_ * (c[0] + g.ox - body_->x[g.i]), stiffness_ * (c[1] + g.oy - body_->y[g.i]),
            stiffness_ * (c[2] + g.oz - body_->z[g.i])};
  }

  Body<S>* body_ = nullptr;
  std::vector<geometry::V3<S>> centre_;  // per tool slot
  std::vector<ToolTrack<S>*> track_;     // per tool slot; null: not holding this body
  S stiffness_ = 0, inv_mass_ = 0;
  int substeps_ = 1;
  bool any_ = false;
};

}  // namespace sculpt::sim
