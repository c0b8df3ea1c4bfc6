// What the commands that talk to a running sculptd share: one connection per
// invocation (to --socket, DaemonArgs in commands.hpp), and one mapping of
// failures to messages and exit statuses:
//   1  the daemon answered but the command failed (its error is printed)
//   3  no daemon is listening (nothing at the socket path)
//   4  the daemon speaks another protocol major, or refused us
//   5  the connection failed or broke (permissions, I/O)
#pragma once

#include <functional>
#include <string>

#include <kj/async-io.h>

#include "client/connection.hpp"
#include "commands.hpp"

namespace sculpt::ctl {

inline constexpr int kExitNoDaemon = 3;
inline constexpr int kExitIncompatible = 4;
inline constexpr int kExitConnection = 5;

// Connects (hello), runs `f` with the connection, maps every failure to a
// message on stderr and a CommandFailed with the status above.
void with_daemon(const DaemonArgs& args, const std::function<void(client::Connection&, kj::WaitScope&)>& f);

// Prints an error line and throws CommandFailed{status}.
[[noreturn]] void fail(int status, const std::string& message);

// Fails with kExitIncompatible, naming both versions, when the daemon
// speaks a protocol minor older than `minor` (what `command` needs).
void require_minor(const client::Connection& c, std::uint16_t minor, const char* command);

}  // namespace sculpt::ctl
