// The Cap'n Proto interfaces one client holds (proto/sculpt.capnp):
// Sculptd (hello, the session), Session (control calls and subscribing) and
// Subscription (one viewer's stream, removed when the client drops it).
// Each turns its calls into the Server's public methods for its client.
#pragma once

#include <cstdint>
#include <string>

#include <kj/memory.h>

#include "server/server.hpp"

namespace sculpt::server {

kj::Own<proto::Sculptd::Server> make_sculptd(Server& server, std::uint64_t client, std::string peer);

}  // namespace sculpt::server
