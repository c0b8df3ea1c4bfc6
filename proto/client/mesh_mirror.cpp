#include "client/mesh_mirror.hpp"

#include <cstring>

namespace sculpt::client {
namespace {

std::vector<float> floats_of(capnp::Data::Reader d, const std::string& what) {
  if (d.size() % 12 != 0)
    throw MirrorError(what + ": " + std::to_string(d.size()) + " bytes is not a whole number of x,y,z float triples");
  std::vector<float> out(d.size() / 4);
  if (!out.empty()) std::memcpy(out.data(), d.begin(), d.size());
  return out;
}

std::array<float, 3> vec(proto::Vec3::Reader v) { return {v.getX(), v.getY(), v.getZ()}; }

}  // namespace

int MeshMirror::index_of(std::uint32_t mesh_id) const {
  for (std::size_t i = 0; i < meshes_.size(); ++i)
    if (meshes_[i].id == mesh_id) return static_cast<int>(i);
  return -1;
}

void MeshMirror::read_tools(capnp::List<proto::Tool>::Reader tools) {
  tools_.resize(tools.size());
  for (unsigned i = 0; i < tools.size(); ++i) {
    const auto t = tools[i];
    MirrorTool& m = tools_[i];
    m.id = t.getId();
    m.shape = t.getShape();
    m.radius = t.getRadius();
    m.half_length = t.getHalfLength();
    m.position = vec(t.getPosition());
    m.velocity = vec(t.getVelocity());
    m.contact_force = vec(t.getContactForce());
    const auto q = t.getOrientation();
    m.orientation = {q.getW(), q.getX(), q.getY(), q.getZ()};
    m.grabbing = t.getGrabbing();
    m.contacts = t.getContacts();
    m.device_slot = t.getDeviceSlot();
  }
}

std::span<const ChangedRange> MeshMirror::apply(proto::Keyframe::Reader s) {
  std::vector<MirrorMesh> meshes;
  for (const auto m : s.getMeshes()) {
    MirrorMesh out;
    out.id = m.getId();
    out.name = m.getName();
    const std::string what = "keyframe mesh " + std::to_string(out.id) + " (" + out.name + ")";
    out.positions = floats_of(m.getPositions(), what + " positions");
    out.rest = floats_of(m.getRestPositions(), what + " restPositions");
    if (out.rest.size() != out.positions.size())
      throw MirrorError(what + ": " + std::to_string(out.rest.size() / 3) + " rest positions but " +
                        std::to_string(out.positions.size() / 3) + " positions");
    const auto tris = m.getTriangles();
    if (tris.size() % 3 != 0) throw MirrorError(what + ": triangles is not a multiple of 3 indices");
    out.triangles.reserve(tris.size());
    for (const auto i : tris) {
      if (i >= out.vertices())
        throw MirrorError(what + ": triangle index " + std::to_string(i) + " >= " + std::to_string(out.vertices()) +
                          " vertices");
      out.triangles.push_back(i);
    }
    out.lo = vec(m.getBounds().getMin());
    out.hi = vec(m.getBounds().getMax());
    meshes.push_back(std::move(out));
  }
  meshes_ = std::move(meshes);
  read_tools(s.getTools());
  sequence_ = s.getSequence();
  sim_time_ns_ = s.getSimTimeNs();
  has_keyframe_ = true;
  changed_.clear();
  for (std::size_t i = 0; i < meshes_.size(); ++i)
    if (meshes_[i].vertices() > 0)
      changed_.push_back({static_cast<std::uint32_t>(i), 0, static_cast<std::uint32_t>(meshes_[i].vertices())});
  return changed_;
}

std::span<const ChangedRange> MeshMirror::apply(proto::DeltaFrame::Reader f) {
  if (!has_keyframe_) throw MirrorError("delta frame " + std::to_string(f.getSequence()) + " before any keyframe");
  // Check everything first: a bad frame changes nothing.
  const auto deltas = f.getMeshes();
  std::vector<int> where(deltas.size());
  for (unsigned d = 0; d < deltas.size(); ++d) {
    const auto md = deltas[d];
    const std::string what = "frame " + std::to_string(f.getSequence()) + " mesh " + std::to_string(md.getMeshId());
    const int mi = index_of(md.getMeshId());
    if (mi < 0) throw MirrorError(what + ": not in the keyframe");
    where[d] = mi;
    const auto idx = md.getIndices();
    if (md.getPositions().size() != std::size_t{idx.size()} * 12)
      throw MirrorError(what + ": " + std::to_string(idx.size()) + " indices but " +
                        std::to_string(md.getPositions().size()) + " bytes of positions");
    const std::size_t n = meshes_[static_cast<std::size_t>(mi)].vertices();
    std::int64_t prev = -1;
    for (const auto i : idx) {
      if (i >= n) throw MirrorError(what + ": index " + std::to_string(i) + " >= " + std::to_string(n) + " vertices");
      if (static_cast<std::int64_t>(i) <= prev) throw MirrorError(what + ": indices not ascending at " + std::to_string(i));
      prev = i;
    }
  }
  changed_.clear();
  for (unsigned d = 0; d < deltas.size(); ++d) {
    const auto md = deltas[d];
    MirrorMesh& m = meshes_[static_cast<std::size_t>(where[d])];
    const auto idx = md.getIndices();
    const auto bytes = md.getPositions();
    const auto mesh = static_cast<std::uint32_t>(where[d]);
    for (unsigned k = 0; k < idx.size(); ++k) {
      const std::uint32_t i = idx[k];
      std::memcpy(&m.positions[std::size_t{i} * 3], bytes.begin() + std::size_t{k} * 12, 12);
      if (!changed_.empty() && changed_.back().mesh == mesh && i <= changed_.back().end + merge_gap_)
        changed_.back().end = i + 1;
      else
        changed_.push_back({mesh, i, i + 1});
    }
    m.lo = vec(md.getBounds().getMin());
    m.hi = vec(md.getBounds().getMax());
  }
  read_tools(f.getTools());
  sequence_ = f.getSequence();
  sim_time_ns_ = f.getSimTimeNs();
  published_ns_ = f.getPublishedNs();
  ++frames_;
  if (deltas.size() == 0) ++keepalives_;
  return changed_;
}

}  // namespace sculpt::client
