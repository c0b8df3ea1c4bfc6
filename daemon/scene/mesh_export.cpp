#include "scene/mesh_export.hpp"

#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "files/atomic_file.hpp"
#include "scene/errors.hpp"

namespace sculpt::scene {
namespace {

static_assert(std::endian::native == std::endian::little,
              "binary PLY/STL/GLB writers copy little-endian floats directly");

using sim::Vec3f;

Vec3f cross_of(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  const float ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
  const float vx = c[0] - a[0], vy = c[1] - a[1], vz = c[2] - a[2];
  return {uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx};
}

Vec3f normalized(Vec3f v) {
  const float len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (!(len > 0.0f) || !std::isfinite(len)) return {0.0f, 0.0f, 1.0f};
  return {v[0] / len, v[1] / len, v[2] / len};
}

template <class T>
void put(std::string& out, const T& value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof value);
}

std::string encode_obj(const sim::TriangleMesh& m, const std::vector<Vec3f>& n) {
  std::string out = "# exported by sculptd\n";
  out.reserve(m.positions.size() * 80 + m.triangles.size() * 40);
  // {} prints the shortest text that reads back to the same float: exact round trip.
  for (const Vec3f& p : m.positions) fmt::format_to(std::back_inserter(out), "v {} {} {}\n", p[0], p[1], p[2]);
  for (const Vec3f& v : n) fmt::format_to(std::back_inserter(out), "vn {} {} {}\n", v[0], v[1], v[2]);
  for (const sim::Triangle& t : m.triangles) {
    fmt::format_to(std::back_inserter(out), "f {0}//{0} {1}//{1} {2}//{2}\n", t[0] + 1, t[1] + 1, t[2] + 1);
  }
  return out;
}

std::string encode_ply(const sim::TriangleMesh& m, const std::vector<Vec3f>& n) {
  std::string out = fmt::format(
      "ply\nformat binary_little_endian 1.0\ncomment exported by sculptd\n"
      "element vertex {}\nproperty float x\nproperty float y\nproperty float z\n"
      "property float nx\nproperty float ny\nproperty float nz\n"
      "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
      m.positions.size(), m.triangles.size());
  out.reserve(out.size() + m.positions.size() * 24 + m.triangles.size() * 13);
  for (std::size_t i = 0; i < m.positions.size(); ++i) {
    put(out, m.positions[i]);
    put(out, n[i]);
  }
  for (const sim::Triangle& t : m.triangles) {
    put(out, std::uint8_t{3});
    for (std::uint32_t v : t) put(out, static_cast<std::int32_t>(v));
  }
  return out;
}

std::string encode_stl(const sim::TriangleMesh& m) {
  std::string out(80, ' ');
  // A binary STL header must not begin with "solid": readers would take it for ASCII.
  std::memcpy(out.data(), "binary STL exported by sculptd", 30);
  put(out, static_cast<std::uint32_t>(m.triangles.size()));
  out.reserve(out.size() + m.triangles.size() * 50);
  for (const sim::Triangle& t : m.triangles) {
    const Vec3f& a = m.positions[t[0]];
    const Vec3f& b = m.positions[t[1]];
    const Vec3f& c = m.positions[t[2]];
    put(out, normalized(cross_of(a, b, c)));
    put(out, a);
    put(out, b);
    put(out, c);
    put(out, std::uint16_t{0});
  }
  return out;
}

std::string encode_glb(const sim::TriangleMesh& m, const std::vector<Vec3f>& n) {
  const std::size_t nv = m.positions.size(), nt = m.triangles.size();
  Vec3f lo = m.positions.front(), hi = lo;
  for (const Vec3f& p : m.positions)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], p[k]);
      hi[k] = std::max(hi[k], p[k]);
    }
  const std::size_t pos_bytes = nv * 12, idx_bytes = nt * 12;
  const nlohmann::json gltf = {
      {"asset", {{"version", "2.0"}, {"generator", "sculptd"}}},
      {"scene", 0},
      {"scenes", {{{"nodes", {0}}}}},
      {"nodes", {{{"mesh", 0}}}},
      {"meshes",
       {{{"primitives",
          {{{"attributes", {{"POSITION", 0}, {"NORMAL", 1}}}, {"indices", 2}, {"mode", 4}}}}}}},
      {"accessors",
       {{{"bufferView", 0}, {"componentType", 5126}, {"count", nv}, {"type", "VEC3"},
         {"min", {lo[0], lo[1], lo[2]}}, {"max", {hi[0], hi[1], hi[2]}}},
        {{"bufferView", 1}, {"componentType", 5126}, {"count", nv}, {"type", "VEC3"}},
        {{"bufferView", 2}, {"componentType", 5125}, {"count", nt * 3}, {"type", "SCALAR"}}}},
      {"bufferViews",
       {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", pos_bytes}, {"target", 34962}},
        {{"buffer", 0}, {"byteOffset", pos_bytes}, {"byteLength", pos_bytes}, {"target", 34962}},
        {{"buffer", 0}, {"byteOffset", 2 * pos_bytes}, {"byteLength", idx_bytes}, {"target", 34963}}}},
      {"buffers", {{{"byteLength", 2 * pos_bytes + idx_bytes}}}},
  };
  std::string json = gltf.dump();
  while (json.size() % 4) json.push_back(' ');  // chunks are 4-byte aligned; JSON pads with spaces
  std::string bin;
  bin.reserve(2 * pos_bytes + idx_bytes);
  for (const Vec3f& p : m.positions) put(bin, p);
  for (const Vec3f& v : n) put(bin, v);
  for (const sim::Triangle& t : m.triangles) put(bin, t);
  // 12-byte elements keep the binary chunk a multiple of 4 already.

  std::string out;
  const auto total = static_cast<std::uint32_t>(12 + 8 + json.size() + 8 + bin.size());
  out.reserve(total);
  put(out, std::uint32_t{0x46546C67});  // "glTF"
  put(out, std::uint32_t{2});
  put(out, total);
  put(out, static_cast<std::uint32_t>(json.size()));
  put(out, std::uint32_t{0x4E4F534A});  // "JSON"
  out += json;
  put(out, static_cast<std::uint32_t>(bin.size()));
  put(out, std::uint32_t{0x004E4942});  // "BIN\0"
  out += bin;
  return out;
}

}  // namespace

std::vector<Vec3f> vertex_normals(const sim::TriangleMesh& m) {
  std::vector<std::array<double, 3>> sum(m.positions.size(), {0.0, 0.0, 0.0});
  for (const sim::Triangle& t : m.triangles) {
    // The unnormalised cross product is twice the area: larger faces weigh more.
    const Vec3f c = cross_of(m.positions[t[0]], m.positions[t[1]], m.positions[t[2]]);
    for (std::uint32_t v : t)
      for (int k = 0; k < 3; ++k) sum[v][k] += c[k];
  }
  std::vector<Vec3f> out(m.positions.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i] = normalized({static_cast<float>(sum[i][0]), static_cast<float>(sum[i][1]),
                         static_cast<float>(sum[i][2])});
  }
  return out;
}

std::string encode_mesh(const sim::TriangleMesh& mesh, ExportFormat format) {
  if (mesh.positions.empty() || mesh.triangles.empty()) throw std::invalid_argument("the mesh is empty");
  for (const sim::Triangle& t : mesh.triangles)
    for (std::uint32_t v : t)
      if (v >= mesh.positions.size()) throw std::invalid_argument("a triangle refers to a missing vertex");
  for (const Vec3f& p : mesh.positions)
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
      throw std::invalid_argument("a vertex has a non-finite coordinate");
  switch (format) {
    case ExportFormat::obj: return encode_obj(mesh, vertex_normals(mesh));
    case ExportFormat::ply: return encode_ply(mesh, vertex_normals(mesh));
    case ExportFormat::stl: return encode_stl(mesh);
    case ExportFormat::glb: return encode_glb(mesh, vertex_normals(mesh));
  }
  throw std::invalid_argument("unknown export format");
}

void export_mesh(const sim::TriangleMesh& mesh, const std::filesystem::path& file) {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  ExportFormat format;
  if (ext == ".obj") format = ExportFormat::obj;
  else if (ext == ".ply") format = ExportFormat::ply;
  else if (ext == ".stl") format = ExportFormat::stl;
  else if (ext == ".glb") format = ExportFormat::glb;
  else
    throw ExportError(file, fmt::format("unknown export format '{}' (use .obj, .ply, .stl or .glb)",
                                        ext.empty() ? std::string("no extension") : ext));
  std::string bytes;
  try {
    bytes = encode_mesh(mesh, format);
  } catch (const std::invalid_argument& e) {
    throw ExportError(file, e.what());
  }
  try {
    files::write_file_atomically(file, bytes);
  } catch (const files::FileError& e) {
    throw ExportError(file, e.reason());
  }
}

}  // namespace sculpt::scene
