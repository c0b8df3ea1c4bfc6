#include "scene/raw_blob.hpp"

#include <cstdint>
#include <algorithm>
#include <cstring>
#include <string>
#include <stdexcept>

namespace sculpt::scene {
namespace {

constexpr std::uint32_t kMagic = 0x57524353;  // "SCRW"

struct Header {
  std::uint32_t magic;
  std::uint32_t reserved;
  std::uint64_t positions;
  std::uint64_t triangles;
  std::uint64_t skipped_primitives;
  std::uint64_t source_meshes;
  std::uint64_t warning_bytes;  // then: warnings, each a u32 length and its text
};

static_assert(sizeof(sim::Vec3f) == 12 && sizeof(sim::Triangle) == 12);

}  // namespace

std::vector<std::byte> encode_raw(const RawImport& raw) {
  std::string warnings;
  for (const std::string& w : raw.importer_warnings) {
    const auto n = static_cast<std::uint32_t>(std::min<std::size_t>(w.size(), 4096));
    warnings.append(reinterpret_cast<const char*>(&n), sizeof n);
    warnings.append(w, 0, n);
  }
  const Header h{kMagic, 0, raw.mesh.positions.size(), raw.mesh.triangles.size(),
                 raw.skipped_primitives, raw.source_meshes, warnings.size()};
  const std::size_t pb = raw.mesh.positions.size() * sizeof(sim::Vec3f);
  const std::size_t tb = raw.mesh.triangles.size() * sizeof(sim::Triangle);
  std::vector<std::byte> out(sizeof h + warnings.size() + pb + tb);
  std::byte* p = out.data();
  std::memcpy(p, &h, sizeof h);
  p += sizeof h;
  if (!warnings.empty()) std::memcpy(p, warnings.data(), warnings.size());
  p += warnings.size();
  if (pb) std::memcpy(p, raw.mesh.positions.data(), pb);
  p += pb;
  if (tb) std::memcpy(p, raw.mesh.triangles.data(), tb);
  return out;
}

RawImport decode_raw(std::span<const std::byte> bytes) {
  Header h{};
  if (bytes.size() < sizeof h) throw std::runtime_error("the importer returned a truncated result");
  std::memcpy(&h, bytes.data(), sizeof h);
  if (h.magic != kMagic) throw std::runtime_error("the importer returned a malformed result");
  if (h.warning_bytes > bytes.size() - sizeof h) {
    throw std::runtime_error("the importer returned a result of the wrong size");
  }
  RawImport raw;
  {
    const std::byte* w = bytes.data() + sizeof h;
    std::size_t left = h.warning_bytes;
    while (left) {
      std::uint32_t n = 0;
      if (left < sizeof n) throw std::runtime_error("the importer returned malformed warnings");
      std::memcpy(&n, w, sizeof n);
      w += sizeof n;
      left -= sizeof n;
      if (n > left) throw std::runtime_error("the importer returned malformed warnings");
      raw.importer_warnings.emplace_back(reinterpret_cast<const char*>(w), n);
      w += n;
      left -= n;
    }
  }
  const std::size_t body = bytes.size() - sizeof h - h.warning_bytes;
  // Compare counts against the body before multiplying, so no product can overflow.
  if (h.positions > body / sizeof(sim::Vec3f) || h.triangles > body / sizeof(sim::Triangle) ||
      h.positions * sizeof(sim::Vec3f) + h.triangles * sizeof(sim::Triangle) != body) {
    throw std::runtime_error("the importer returned a result of the wrong size");
  }
  raw.skipped_primitives = h.skipped_primitives;
  raw.source_meshes = h.source_meshes;
  raw.mesh.positions.resize(h.positions);
  raw.mesh.triangles.resize(h.triangles);
  const std::byte* p = bytes.data() + sizeof h + h.warning_bytes;
  if (h.positions) std::memcpy(raw.mesh.positions.data(), p, h.positions * sizeof(sim::Vec3f));
  p += h.positions * sizeof(sim::Vec3f);
  if (h.triangles) std::memcpy(raw.mesh.triangles.data(), p, h.triangles * sizeof(sim::Triangle));
  return raw;
}

}  // namespace sculpt::scene
