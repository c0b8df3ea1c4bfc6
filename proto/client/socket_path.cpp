#include "client/socket_path.hpp"

#include <cstdlib>

namespace sculpt::client {

std::string resolve_socket_path(std::string_view explicit_path,
                                const std::function<const char*(const char*)>& getenv) {
  if (!explicit_path.empty()) return std::string(explicit_path);
  auto var = [&](const char* name) -> std::string {
    const char* v = getenv(name);
    return v ? std::string(v) : std::string();
  };
  if (auto s = var("SCULPTD_SOCKET"); !s.empty()) return s;
  if (auto d = var("RUNTIME_DIRECTORY"); !d.empty()) {
    // systemd may list several directories separated by ':'; ours is the first.
    if (auto colon = d.find(':'); colon != std::string::npos) d.resize(colon);
    return d + "/sculptd.sock";
  }
  if (auto x = var("XDG_RUNTIME_DIR"); !x.empty()) return x + "/sculptd/sculptd.sock";
  return kSystemSocketPath;
}

std::string resolve_socket_path(std::string_view explicit_path) {
  return resolve_socket_path(explicit_path, [](const char* n) -> const char* { return std::getenv(n); });
}

}  // namespace sculpt::client
