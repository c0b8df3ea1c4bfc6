// Where sculptd listens, decided the same way by the daemon and every client:
//   1. an explicit path (--socket, or the daemon's config file `socket`),
//   2. else $SCULPTD_SOCKET,
//   3. else $RUNTIME_DIRECTORY/sculptd.sock (systemd's RuntimeDirectory=),
//   4. else $XDG_RUNTIME_DIR/sculptd/sculptd.sock (a user's own daemon),
//   5. else /run/sculptd/sculptd.sock (what sculptd.socket creates).
// Socket activation overrides the daemon's choice (systemd hands it the fd),
// so clients of a system daemon set $SCULPTD_SOCKET or --socket when their
// own environment would point elsewhere.
#pragma once

#include <functional>
#include <string>
#include <string_view>

namespace sculpt::client {

inline constexpr const char* kSystemSocketPath = "/run/sculptd/sculptd.sock";

// `getenv` is injectable for tests; it returns nullptr for unset variables.
// Empty variables count as unset.
std::string resolve_socket_path(std::string_view explicit_path,
                                const std::function<const char*(const char*)>& getenv);
std::string resolve_socket_path(std::string_view explicit_path = {});

}  // namespace sculpt::client
