#include "daemon_link.hpp"

#include <fmt/format.h>

#include "cli/conventions.hpp"
#include "client/socket_path.hpp"
#include "commands.hpp"

namespace sculpt::ctl {

void fail(int status, const std::string& message) {
  cli::error(message);
  throw CommandFailed{status};
}

void require_minor(const client::Connection& c, std::uint16_t minor, const char* command) {
  if (c.server_minor() >= minor) return;
  fail(kExitIncompatible, fmt::format("{}: the daemon ({}) speaks protocol {}.{}; {} needs {}.{} or later (update sculptd)",
                                      command, c.server(), proto::PROTOCOL_MAJOR, c.server_minor(), command,
                                      proto::PROTOCOL_MAJOR, minor));
}

void with_daemon(const DaemonArgs& args, const std::function<void(client::Connection&, kj::WaitScope&)>& f) {
  const std::string path = client::resolve_socket_path(args.socket);
  try {
    auto io = kj::setupAsyncIo();
    client::Connection c(io, path, "sculptctl " SCULPTCTL_VERSION);
    client::guarded("sculptd", [&] { f(c, io.waitScope); });
  } catch (const client::ClientError& e) {
    switch (e.kind()) {
      case client::ClientError::Kind::no_daemon:
        fail(kExitNoDaemon, std::string(e.what()) + " (is sculptd running? --socket or $SCULPTD_SOCKET choose another)");
      case client::ClientError::Kind::incompatible: fail(kExitIncompatible, e.what());
      // The daemon said no (max_clients): its reason is printed, as for a refused command.
      case client::ClientError::Kind::refused: fail(kExitCommandFailed, e.what());
      case client::ClientError::Kind::failed: fail(kExitConnection, e.what());
    }
    fail(kExitConnection, e.what());
  }
}

}  // namespace sculpt::ctl
