// The server's parts shared by its files (server.hpp: Server): server.cpp
// (connections, their limits, status), server_streams.cpp (viewer streams),
// server_history.cpp (undo and redo), server_exports.cpp (exports).
#pragma once

#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <string>
#include <vector>

#include <capnp/rpc-twoparty.h>
#include <fmt/format.h>

#include "files/unique_fd.hpp"
#include "server/checked_stream.hpp"
#include "server/server.hpp"

namespace sculpt::server {

inline constexpr off_t kExportReleaseStep = 1 << 20;  // bytes freed per ftruncate of one let go

// One viewer's stream: its own baseline (what it has: the positions it was
// last sent, per vertex), rate and tolerance. Bounded: one copy of the
// positions, one call in flight.
struct Server::Stream {
  std::uint64_t id = 0, client = 0;
  proto::Viewer::Client viewer;
  float tolerance = 0;
  float fps = 60;
  std::vector<std::vector<float>> baseline;   // per body, file order
  std::uint64_t evaluated = 0;                // reader serial its baseline was compared at
  PublishedHeader sent_header{};              // tools as last sent
  std::uint64_t sequence = 0;                 // of the last frame or keyframe sent
  std::uint64_t keyframes = 0;                // sent to this viewer
  std::int64_t last_send_ns = 0, last_stats_ns = 0;
  bool needs_keyframe = true;
  bool in_flight = false;
  bool dead = false;
  kj::Promise<void> pending = nullptr;

  explicit Stream(proto::Viewer::Client v) : viewer(kj::mv(v)) {}
};

struct Server::Client {
  std::uint64_t id = 0;
  std::string peer;
  std::string name;      // what its hello said it is
  bool hello = false;    // a valid hello arrived (else: garbage, a silent or truncated client)
  std::string refusal;   // served only to be told this (the client table was full)
  std::string violation; // the limit its messages broke (checked_stream.hpp), for the log
  std::int64_t connected_ns = 0;
  std::int64_t answered_ns = 0;  // a refusal: when its answer was written (0: not yet)
  bool closing = false;  // over a limit: dropped at the next turn of the loop
  std::size_t pending_history_moves = 0;  // undo/redo calls being applied
  int fd = -1;           // the socket (owned by `stream`), to see whether the peer is gone
  kj::Own<kj::AsyncIoStream> stream;
  kj::Own<CheckedMessageStream> messages;
  kj::Own<capnp::TwoPartyVatNetwork> network;
  kj::Own<capnp::RpcSystem<capnp::rpc::twoparty::VatId>> rpc;

  std::string who() const {
    return name.empty() ? fmt::format("client {} ({})", id, peer) : fmt::format("client {} ({}, \"{}\")", id, peer, name);
  }
};

// An export: a file the daemon is writing (`landed` fulfilled when it has
// answered: `fd` or `error`), then held by one client's ExportReader (`open`).
struct Server::Export {
  std::uint64_t client = 0;
  kj::Own<kj::PromiseFulfiller<void>> landed;
  std::string error;
  files::UniqueFd fd;
  std::uint64_t size = 0;
  std::int64_t last_read_ns = 0;
  bool open = false;
  // The file has no name: its last close frees all its pages in one stretch
  // in the kernel (a millisecond for 35 MB here), which a real-time thread
  // waking on this CPU waits out. Shrunk in steps first, each short.
  ~Export() {
    if (!fd.valid()) return;
    struct stat st {};
    if (::fstat(fd.get(), &st) != 0 || !S_ISREG(st.st_mode) || st.st_nlink != 0) return;
    for (off_t at = st.st_size; at > 0;) {
      at = at > kExportReleaseStep ? at - kExportReleaseStep : 0;
      if (::ftruncate(fd.get(), at) != 0) return;
    }
  }
};

}  // namespace sculpt::server
