#include "lab/deltas.hpp"

#include <capnp/message.h>
#include <capnp/serialize.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "sculpt.capnp.h"

namespace sculpt::lab {

void DeltaEncoder::add_mesh(std::span<const sim::Vec3f> positions) {
  sent_.emplace_back(positions.begin(), positions.end());
}

EncodedFrame DeltaEncoder::encode(std::uint64_t sequence, std::span<const std::span<const sim::Vec3f>> meshes,
                                  std::span<const sim::Tool> tools, std::span<const sim::ToolFeedback> feedback) {
  if (meshes.size() != sent_.size()) throw std::invalid_argument("DeltaEncoder: mesh count changed");
  capnp::MallocMessageBuilder message;
  proto::DeltaFrame::Builder frame = message.initRoot<proto::DeltaFrame>();
  frame.setSequence(sequence);
  frame.setSimTimeNs(sequence * 1000000ull);
  EncodedFrame out;
  std::vector<std::uint32_t> changed_meshes;
  for (std::uint32_t m = 0; m < meshes.size(); ++m) {
    const auto& now = meshes[m];
    const auto& was = sent_[m];
    bool any = false;
    for (std::size_t i = 0; i < now.size() && !any; ++i) {
      double d2 = 0;
      for (int k = 0; k < 3; ++k) d2 += double(now[i][k] - was[i][k]) * double(now[i][k] - was[i][k]);
      any = d2 > tolerance2_;
    }
    if (any) changed_meshes.push_back(m);
  }
  auto list = frame.initMeshes(static_cast<unsigned>(changed_meshes.size()));
  for (std::size_t c = 0; c < changed_meshes.size(); ++c) {
    const std::uint32_t m = changed_meshes[c];
    const auto& now = meshes[m];
    auto& was = sent_[m];
    moved_.clear();
    for (std::uint32_t i = 0; i < now.size(); ++i) {
      double d2 = 0;
      for (int k = 0; k < 3; ++k) d2 += double(now[i][k] - was[i][k]) * double(now[i][k] - was[i][k]);
      if (d2 > tolerance2_) moved_.push_back(i);
    }
    proto::MeshDelta::Builder d = list[static_cast<unsigned>(c)];
    d.setMeshId(m);
    auto idx = d.initIndices(static_cast<unsigned>(moved_.size()));
    auto data = d.initPositions(static_cast<unsigned>(moved_.size() * 12));
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (const sim::Vec3f& p : now)
      for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
    for (std::size_t q = 0; q < moved_.size(); ++q) {
      const std::uint32_t i = moved_[q];
      idx.set(static_cast<unsigned>(q), i);
      std::memcpy(data.begin() + 12 * q, now[i].data(), 12);  // little-endian float32 x,y,z (x86)
      was[i] = now[i];
    }
    auto b = d.initBounds();
    b.initMin().setX(lo[0]), b.getMin().setY(lo[1]), b.getMin().setZ(lo[2]);
    b.initMax().setX(hi[0]), b.getMax().setY(hi[1]), b.getMax().setZ(hi[2]);
    out.vertices += moved_.size();
  }
  out.meshes = changed_meshes.size();
  auto tl = frame.initTools(static_cast<unsigned>(tools.size()));
  for (std::size_t t = 0; t < tools.size(); ++t) {
    proto::Tool::Builder b = tl[static_cast<unsigned>(t)];
    b.setId(static_cast<std::uint32_t>(t));
    b.setShape(tools[t].shape == sim::ToolShape::capsule ? proto::ToolShape::CAPSULE : proto::ToolShape::SPHERE);
    b.setRadius(static_cast<float>(tools[t].radius));
    auto p = b.initPosition();
    p.setX(float(tools[t].position[0])), p.setY(float(tools[t].position[1])), p.setZ(float(tools[t].position[2]));
    b.setGrabbing(tools[t].grab);
    if (t < feedback.size()) {
      auto f = b.initContactForce();
      f.setX(float(feedback[t].force[0])), f.setY(float(feedback[t].force[1])), f.setZ(float(feedback[t].force[2]));
      b.setContacts(feedback[t].contacts);
    }
  }
  const kj::Array<capnp::word> words = capnp::messageToFlatArray(message);
  out.bytes = words.asBytes().size();
  return out;
}

double DeltaEncoder::max_lag(std::span<const std::span<const sim::Vec3f>> meshes) const {
  double worst = 0;
  for (std::size_t m = 0; m < meshes.size() && m < sent_.size(); ++m)
    for (std::size_t i = 0; i < meshes[m].size(); ++i) {
      double d2 = 0;
      for (int k = 0; k < 3; ++k) d2 += double(meshes[m][i][k] - sent_[m][i][k]) * double(meshes[m][i][k] - sent_[m][i][k]);
      worst = std::max(worst, std::sqrt(d2));
    }
  return worst;
}

}  // namespace sculpt::lab
