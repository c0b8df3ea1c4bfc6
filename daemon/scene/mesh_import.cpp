#include "scene/mesh_import.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <system_error>
#include <variant>

#include <fmt/format.h>

#include "files/regular_file.hpp"
#include "scene/assimp_reader.hpp"
#include "scene/isolation.hpp"
#include "scene/raw_blob.hpp"
#include "scene/weld.hpp"
#include "sim/shapes.hpp"

namespace sculpt::scene {
namespace fs = std::filesystem;
namespace {

// Bigger than any mesh the simulation can hold at its rate (a 2M-triangle
// binary STL is 100 MB).
constexpr std::uint64_t kMaxMeshBytes = std::uint64_t{1} << 30;

// assimp messages sometimes span lines; ours are one line.
std::string one_line(std::string s) {
  std::replace_if(s.begin(), s.end(), [](char c) { return c == '\n' || c == '\r' || c == '\t'; }, ' ');
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s.empty() ? std::string("unknown error") : s;
}

// assimp's "no reader" also means "a reader claimed the extension but the
// content is not what it says": say that instead.
std::string explain(const std::string& assimp_message) {
  if (assimp_message.rfind("No suitable reader found", 0) == 0) {
    return "the content is not in a format it claims to be (damaged, truncated, or mislabelled)";
  }
  return one_line(assimp_message);
}

std::string lower_extension(const fs::path& file) {
  std::string ext = file.extension().string();
  if (!ext.empty() && ext.front() == '.') ext.erase(0, 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

template <class Read>
RawImport import_raw(const fs::path& name, const ImportOptions& options, Read&& read) {
  if (!options.isolate) {
    try {
      return read();
    } catch (const std::bad_alloc&) {
      throw LoadError(name, "cannot import: out of memory");
    } catch (const std::exception& e) {
      throw LoadError(name, "cannot import: " + explain(e.what()));
    }
  }
  const ChildLimits limits{options.timeout, options.memory_limit};
  auto result = run_in_child([&] { return encode_raw(read()); }, limits);
  if (auto* failure = std::get_if<ChildFailure>(&result)) {
    throw LoadError(name, "cannot import: " + explain(failure->what));
  }
  try {
    return decode_raw(std::get<std::vector<std::byte>>(result));
  } catch (const std::exception& e) {
    throw LoadError(name, e.what());
  }
}

}  // namespace

LoadedMesh clean_mesh(const sim::TriangleMesh& raw, const fs::path& name, const ImportOptions& options,
                      std::size_t skipped_primitives, std::size_t source_meshes) {
  if (auto problem = find_raw_problem(raw)) throw LoadError(name, *problem);
  if (!(options.weld_tolerance >= 0.0) || !std::isfinite(options.weld_tolerance)) {
    throw LoadError(name, fmt::format("weld tolerance {} is not a number >= 0", options.weld_tolerance));
  }
  sim::Vec3f lo = raw.positions.front(), hi = lo;
  for (const sim::Vec3f& p : raw.positions) {
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], p[k]);
      hi[k] = std::max(hi[k], p[k]);
    }
  }
  double diag2 = 0;
  for (int k = 0; k < 3; ++k) diag2 += (double(hi[k]) - lo[k]) * (double(hi[k]) - lo[k]);
  const auto tolerance = static_cast<float>(options.weld_tolerance * std::sqrt(diag2));

  WeldResult welded = weld(raw, tolerance);
  if (welded.mesh.triangles.empty()) {
    throw LoadError(name, fmt::format("all {} triangles are degenerate (zero area after welding)",
                                      raw.triangles.size()));
  }
  LoadedMesh out;
  out.mesh = std::move(welded.mesh);
  out.report.welded_away = welded.stats.welded_away;
  out.report.degenerate_dropped = welded.stats.degenerate_dropped;
  out.report.duplicates_dropped = welded.stats.duplicates_dropped;
  out.report.unreferenced_dropped = welded.stats.unreferenced_dropped;
  out.report.skipped_primitives = skipped_primitives;
  out.report.source_meshes = source_meshes;
  measure(out.mesh, out.report);
  // A closed, consistently wound surface with negative volume is inside out
  // (a mirrored export): turn it, or every push would pull.
  if (out.report.boundary_edges == 0 && out.report.nonmanifold_edges == 0 && out.report.inconsistent_edges == 0 &&
      sim::signed_volume(out.mesh) < 0.0) {
    for (sim::Triangle& t : out.mesh.triangles) std::swap(t[1], t[2]);
    out.report.flipped = true;
  }
  out.warnings = describe_problems(out.report);
  return out;
}

namespace {

// assimp "repairs" an out-of-range face index by clamping it (OFF, some OBJ),
// which silently welds the face to the wrong vertex: that is a broken file,
// not a warning.
void reject_clamped_indices(const RawImport& raw, const fs::path& file) {
  for (const std::string& w : raw.importer_warnings) {
    std::string lower = w;
    std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
    if (lower.find("index") != std::string::npos && lower.find("out of range") != std::string::npos) {
      throw LoadError(file, "a face refers to a vertex index out of range (" + w + ")");
    }
  }
}

LoadedMesh finish_import(RawImport&& raw, const fs::path& file, const ImportOptions& options) {
  reject_clamped_indices(raw, file);
  LoadedMesh out = clean_mesh(raw.mesh, file, options, raw.skipped_primitives, raw.source_meshes);
  out.warnings.insert(out.warnings.begin(), raw.importer_warnings.begin(), raw.importer_warnings.end());
  return out;
}

}  // namespace

LoadedMesh load_mesh(const fs::path& file, const ImportOptions& options) {
  std::error_code ec;
  const fs::file_status status = fs::status(file, ec);
  if (!fs::exists(status)) throw LoadError(file, "no such file");
  if (fs::is_directory(status)) throw LoadError(file, "is a directory, not a mesh file");
  // A FIFO or a device would block or never end in the importer: regular
  // files only (the importer opens it again itself, in its child).
  std::uint64_t size = 0;
  try {
    size = files::check_regular(file, kMaxMeshBytes);
  } catch (const files::FileError& e) {
    throw LoadError(file, e.reason());
  }
  const std::string ext = lower_extension(file);
  if (!assimp_reads_extension(ext)) {
    throw LoadError(file, fmt::format("unknown mesh format '{}' (readable: obj, ply, stl, gltf, glb, off, "
                                      "fbx, dae, 3ds and more; `sculptctl inspect --formats` lists all)",
                                      ext.empty() ? std::string("no extension") : "." + ext));
  }
  if (size == 0) throw LoadError(file, "the file is empty");
  return finish_import(import_raw(file, options, [&] { return read_with_assimp(file); }), file, options);
}

LoadedMesh load_mesh_from_memory(std::span<const std::byte> bytes, const std::string& format_hint,
                                 const fs::path& name, const ImportOptions& options) {
  if (bytes.empty()) throw LoadError(name, "the file is empty");
  return finish_import(import_raw(name, options, [&] { return read_with_assimp(bytes, format_hint); }), name,
                       options);
}

std::vector<std::string> import_extensions() { return assimp_import_extensions(); }

}  // namespace sculpt::scene
