// What a viewer would be sent: per viewer, a baseline of the positions it last
// received; each frame carries only the vertices that moved more than the
// tolerance since then, encoded as a real proto/sculpt.capnp DeltaFrame (the
// daemon's stream format). A frame with no moved vertex is a keep-alive: no
// meshes, just the tools.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "sim/tool.hpp"
#include "sim/triangle_mesh.hpp"

namespace sculpt::lab {

struct EncodedFrame {
  std::size_t bytes = 0;     // the unpacked message with its segment table, as written to the socket
  std::size_t vertices = 0;  // vertices carried
  std::size_t meshes = 0;    // meshes with a delta
};

class DeltaEncoder {
 public:
  explicit DeltaEncoder(double tolerance_m) : tolerance2_(tolerance_m * tolerance_m) {}
  // The keyframe the viewer starts from.
  void add_mesh(std::span<const sim::Vec3f> positions);
  // Encodes the frame for the current positions (one span per mesh, as added) and
  // the tools, and moves the viewer's baseline to what it carried.
  EncodedFrame encode(std::uint64_t sequence, std::span<const std::span<const sim::Vec3f>> meshes,
                      std::span<const sim::Tool> tools, std::span<const sim::ToolFeedback> feedback);
  // The largest distance between the viewer's copy and `meshes` (≤ the tolerance after encode).
  double max_lag(std::span<const std::span<const sim::Vec3f>> meshes) const;

 private:
  double tolerance2_;
  std::vector<std::vector<sim::Vec3f>> sent_;
  std::vector<std::uint32_t> moved_;  // scratch
};

}  // namespace sculpt::lab
