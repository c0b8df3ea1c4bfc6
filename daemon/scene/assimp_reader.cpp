#include "scene/assimp_reader.hpp"

#include <algorithm>
#include <mutex>
#include <stdexcept>

#include <assimp/DefaultLogger.hpp>
#include <assimp/Importer.hpp>
#include <assimp/Logger.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

namespace sculpt::scene {
namespace {

// No aiProcess_JoinIdenticalVertices: it merges only when every attribute
// matches, so STL and faceted OBJ stay split; our weld by position does the job.
constexpr unsigned kFlags = aiProcess_Triangulate | aiProcess_PreTransformVertices |
                            aiProcess_DropNormals | aiProcess_SortByPType |
                            aiProcess_ValidateDataStructure;

// assimp reports repairs it made (an OFF index clamped into range, a bad
// material skipped) only through its global logger: collect its warnings and
// errors so they reach the user as warnings of the load.
class CaptureLogger final : public Assimp::Logger {
 public:
  std::vector<std::string> messages;

  bool attachStream(Assimp::LogStream*, unsigned) override { return false; }
  bool detachStream(Assimp::LogStream*, unsigned) override { return false; }

 private:
  void OnDebug(const char*) override {}
  void OnVerboseDebug(const char*) override {}
  void OnInfo(const char*) override {}
  void OnWarn(const char* message) override { keep(message); }
  void OnError(const char* message) override { keep(message); }
  void keep(const char* message) {
    std::string m = message ? message : "";
    if (m.empty() || messages.size() >= 20) return;
    if (std::find(messages.begin(), messages.end(), m) == messages.end()) messages.push_back(std::move(m));
  }
};

// The logger is process-global: one import at a time per process.
std::mutex g_import_mutex;

template <class Read>
RawImport with_captured_log(Read&& read) {
  std::lock_guard lock(g_import_mutex);
  auto* logger = new CaptureLogger;
  Assimp::DefaultLogger::set(logger);  // takes ownership
  struct Reset {
    ~Reset() { Assimp::DefaultLogger::set(nullptr); }  // deletes our logger
  } reset;
  RawImport raw = read();
  for (const std::string& m : logger->messages) raw.importer_warnings.push_back("assimp: " + m);
  return raw;
}

RawImport flatten(const aiScene* scene, Assimp::Importer& importer) {
  if (!scene) throw std::runtime_error(importer.GetErrorString());
  if (scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE) throw std::runtime_error("the file is incomplete");
  RawImport out;
  std::size_t total_vertices = 0, total_faces = 0;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    total_vertices += scene->mMeshes[m]->mNumVertices;
    total_faces += scene->mMeshes[m]->mNumFaces;
  }
  out.mesh.positions.reserve(total_vertices);
  out.mesh.triangles.reserve(total_faces);
  // Every mesh of the file goes into one body: a file is one thing to sculpt.
  // Pieces that touch weld together; the rest stay separate components.
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* mesh = scene->mMeshes[m];
    const auto base = static_cast<std::uint32_t>(out.mesh.positions.size());
    std::size_t triangles = 0;
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3) {
        ++out.skipped_primitives;
        continue;
      }
      // Range is checked later (find_raw_problem) against the merged arrays;
      // here only keep one mesh's bad index from pointing into another.
      sim::Triangle t{};
      for (int k = 0; k < 3; ++k) {
        const unsigned i = face.mIndices[k];
        t[k] = i < mesh->mNumVertices ? base + i : 0xFFFFFFFFu;
      }
      out.mesh.triangles.push_back(t);
      ++triangles;
    }
    if (triangles == 0) continue;
    ++out.source_meshes;
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const aiVector3D& p = mesh->mVertices[v];
      out.mesh.positions.push_back({p.x, p.y, p.z});
    }
  }
  return out;
}

}  // namespace

RawImport read_with_assimp(const std::filesystem::path& file) {
  return with_captured_log([&] {
    Assimp::Importer importer;
    return flatten(importer.ReadFile(file.string(), kFlags), importer);
  });
}

RawImport read_with_assimp(std::span<const std::byte> bytes, const std::string& format_hint) {
  if (bytes.empty()) throw std::runtime_error("the file is empty");
  return with_captured_log([&] {
    Assimp::Importer importer;
    return flatten(importer.ReadFileFromMemory(bytes.data(), bytes.size(), kFlags, format_hint.c_str()),
                   importer);
  });
}

bool assimp_reads_extension(const std::string& extension) {
  Assimp::Importer importer;
  return !extension.empty() && importer.IsExtensionSupported("." + extension);
}

std::vector<std::string> assimp_import_extensions() {
  Assimp::Importer importer;
  std::string list;  // "*.3ds;*.obj;..."
  importer.GetExtensionList(list);
  std::vector<std::string> out;
  std::size_t pos = 0;
  while (pos < list.size()) {
    std::size_t end = list.find(';', pos);
    if (end == std::string::npos) end = list.size();
    std::string item = list.substr(pos, end - pos);
    if (item.rfind("*.", 0) == 0) out.push_back(item.substr(2));
    pos = end + 1;
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace sculpt::scene
