// `sculptctl save FILE [--mesh NAME] [--json]`: the running daemon's current
// shapes, exported here (with the caller's permissions) in the format the
// file's extension names (.obj .ply .stl .glb), atomically. All meshes go
// into one file unless --mesh picks one.
#include <cstring>
#include <iostream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "daemon_link.hpp"
#include "scene/mesh_export.hpp"

namespace sculpt::ctl {

void save(const SaveArgs& args) {
  sim::TriangleMesh out;
  std::size_t meshes = 0;
  with_daemon(args.daemon, [&](client::Connection& c, kj::WaitScope& ws) {
    auto reply = c.session().keyframeRequest().send().wait(ws);
    for (const auto m : reply.getKeyframe().getMeshes()) {
      if (!args.mesh.empty() && args.mesh != m.getName().cStr()) continue;
      const auto base = static_cast<std::uint32_t>(out.positions.size());
      const auto pos = m.getPositions();
      const std::size_t n = pos.size() / 12;
      for (std::size_t i = 0; i < n; ++i) {
        sim::Vec3f p;
        std::memcpy(p.data(), pos.begin() + i * 12, 12);
        out.positions.push_back(p);
      }
      const auto tris = m.getTriangles();
      for (unsigned t = 0; t + 2 < tris.size(); t += 3)
        out.triangles.push_back({base + tris[t], base + tris[t + 1], base + tris[t + 2]});
      ++meshes;
    }
  });
  if (meshes == 0) fail(kExitCommandFailed, args.mesh.empty() ? "the daemon's scene has no meshes"
                                                           : "the daemon's scene has no mesh named \"" + args.mesh + "\"");
  try {
    scene::export_mesh(out, args.file);
  } catch (const std::exception& e) {
    fail(kExitCommandFailed, e.what());
  }
  if (args.daemon.json)
    std::cout << nlohmann::json{{"file", args.file}, {"meshes", meshes}, {"vertices", out.positions.size()},
                                {"triangles", out.triangles.size()}}.dump() << "\n";
  else
    fmt::print("saved {} mesh(es), {} vertices, {} triangles to {}\n", meshes, out.positions.size(),
               out.triangles.size(), args.file);
}

}  // namespace sculpt::ctl
