// A viewer's local copy of the daemon's meshes, kept current from the stream:
// apply the Keyframe, then every DeltaFrame, in the order they arrive. Each
// apply says which vertex ranges changed, so a renderer re-uploads only
// those ranges of its vertex buffers.
//
//   sculpt::client::MeshMirror mirror;
//   // in Viewer::keyframe:  mirror.apply(params.getKeyframe());  → upload everything
//   // in Viewer::frame:
//   for (const auto& r : mirror.apply(params.getFrame()))
//     upload(mirror.meshes()[r.mesh].positions, r.begin, r.end);   // vertices [begin, end)
//
// Positions are in each mesh file's own vertex order (the order of
// `triangles`' indices), 3 floats per vertex. A frame that does not fit the
// keyframe (unknown mesh, index out of range, sizes that disagree) throws
// MirrorError and changes nothing: the caller should resubscribe.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "sculpt.capnp.h"

namespace sculpt::client {

class MirrorError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct MirrorMesh {
  std::uint32_t id = 0;
  std::string name;
  std::vector<std::uint32_t> triangles;  // 3 per triangle
  std::vector<float> rest;               // x,y,z per vertex
  std::vector<float> positions;          // x,y,z per vertex, current
  std::array<float, 3> lo{}, hi{};       // bounds of the current positions (as the daemon sent them)
  std::size_t vertices() const { return positions.size() / 3; }
};

struct MirrorTool {
  std::uint32_t id = 0;
  proto::ToolShape shape = proto::ToolShape::SPHERE;
  float radius = 0, half_length = 0;
  std::array<float, 3> position{}, velocity{}, contact_force{};
  std::array<float, 4> orientation{1, 0, 0, 0};  // w, x, y, z
  bool grabbing = false;
  std::uint32_t contacts = 0;
  std::int32_t device_slot = -1;  // the device slot driving it, -1: none
};

// Vertices [begin, end) of meshes()[mesh] changed.
struct ChangedRange {
  std::uint32_t mesh = 0;
  std::uint32_t begin = 0;
  std::uint32_t end = 0;
};

class MeshMirror {
 public:
  // Indices closer than this are reported as one range (re-uploading a few
  // unchanged vertices is cheaper than many tiny uploads). 0: exact runs.
  explicit MeshMirror(std::uint32_t merge_gap = 8) : merge_gap_(merge_gap) {}

  // Replaces everything; every vertex of every mesh counts as changed.
  std::span<const ChangedRange> apply(proto::Keyframe::Reader keyframe);
  // Throws MirrorError before a keyframe, or when the frame does not fit it.
  std::span<const ChangedRange> apply(proto::DeltaFrame::Reader frame);

  bool has_keyframe() const { return has_keyframe_; }
  const std::vector<MirrorMesh>& meshes() const { return meshes_; }
  const std::vector<MirrorTool>& tools() const { return tools_; }
  std::uint64_t sequence() const { return sequence_; }
  std::uint64_t sim_time_ns() const { return sim_time_ns_; }
  std::int64_t published_ns() const { return published_ns_; }  // of the last frame (CLOCK_MONOTONIC)
  std::uint64_t frames() const { return frames_; }
  std::uint64_t keepalives() const { return keepalives_; }       // frames without mesh changes
  // meshes() index of a mesh id, or -1.
  int index_of(std::uint32_t mesh_id) const;

 private:
  void read_tools(capnp::List<proto::Tool>::Reader tools);

  std::uint32_t merge_gap_;
  bool has_keyframe_ = false;
  std::vector<MirrorMesh> meshes_;
  std::vector<MirrorTool> tools_;
  std::vector<ChangedRange> changed_;
  std::uint64_t sequence_ = 0, sim_time_ns_ = 0, frames_ = 0, keepalives_ = 0;
  std::int64_t published_ns_ = 0;
};

}  // namespace sculpt::client
