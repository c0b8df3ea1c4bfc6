// The streaming and control server, on the io thread's kj event loop: one
// Cap'n Proto two-party RPC connection per client (unpacked), bootstrap
// `Sculptd` (hello → Session). Viewers subscribe; a pump on the io loop
// reads the sim thread's PublishedState and sends each viewer what moved
// beyond ITS tolerance since what IT last received, at most its maxFps, one
// stream call at a time (a viewer still taking the previous frame gets none:
// the next one is computed from the latest state when it is ready).
//
//   server::Server srv(io, control);              // control: the daemon
//   srv.set_scene(info, published);               // at start and after every scene swap (returns the old ones)
//   srv.listen(ListenSocket::open(path).release());
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <capnp/rpc-twoparty.h>
#include <kj/async-io.h>
#include <kj/async-unix.h>

#include "sculpt.capnp.h"
#include "server/daemon_control.hpp"
#include "server/published_state.hpp"

namespace sculpt::server {

// Per-client limits (docs/protocol.md lists them): a client over one is
// disconnected with a log line naming it and the limit; the others never
// notice.
struct ServerOptions {
  std::string name = "sculptd";
  // Connections at once. When the table is full a newcomer takes the place of
  // the oldest connection that has said no hello for a second; with none
  // such, it is told why in an answer to its hello (refused: max_clients) and
  // closed.
  std::size_t max_clients = 64;
  std::size_t max_refusing = 8;              // refusals answered at once; beyond, closed unanswered
  kj::Duration hello_timeout = 5 * kj::SECONDS;  // a connection that says no hello within this is closed
  kj::Duration pump_period = 2 * kj::MILLISECONDS;
  std::int64_t keepalive_ns = 1'000'000'000; // an idle viewer gets an empty frame this often
  std::int64_t stats_every_ns = 1'000'000'000;
  float default_fps = 60;
  // Limits on every incoming message: a client cannot make the daemon
  // allocate or recurse much. Cap'n Proto RPC also refuses to SEND a message
  // larger than its own receive limit, so the size limit is the larger of
  // this and twice the loaded scene's keyframe (fixed per connection when it
  // is accepted; a later, bigger scene needs viewers to reconnect only past it).
  std::uint64_t traversal_limit_words = 8 * 1024 * 1024;   // 64 MiB: keyframes of ~1M vertices
  int nesting_limit = 16;
  // What a client sends: one message at most this big, with at most this
  // many capabilities (checked_stream.hpp).
  std::uint64_t max_message_bytes = 1 << 20;
  unsigned max_message_capabilities = 8;
  // Calls a client has made that are not answered yet, in words of their
  // parameters (capnp's flow limit: past it, its messages are not read).
  std::size_t flow_limit_words = 1 << 17;
  // Replies and frames queued for one client that it has not read: past the
  // larger of this and four keyframes of the scene, it is disconnected.
  std::uint64_t max_queued_bytes = std::uint64_t{64} << 20;
  // Subscriptions one connection may hold (each keeps a copy of the meshes).
  std::size_t max_viewers_per_client = 4;
  // Undo/redo: strokes one call may ask for (1 … this; else refused, naming
  // the count), and such calls of one connection being applied at once
  // (past it, refused until one answers).
  std::uint32_t max_history_move_count = 10000;
  std::size_t max_pending_history_moves_per_client = 4;
  // history: at most this many strokes per call (a page; History.omitted
  // and newer count the rest; 16384 entries are about 2 MB).
  std::size_t max_history_entries = 16384;
  // Exports (each an open file in the daemon until its reader is dropped):
  // those being written or held, per connection and in all; past either the
  // call is refused with the reason. A reader not read for
  // export_idle_timeout is closed (its reads then fail, saying so).
  std::size_t max_exports_per_client = 2;
  std::size_t max_exports = 8;
  kj::Duration export_idle_timeout = 60 * kj::SECONDS;
  // One ExportReader.read answers at most this many bytes (a larger count is
  // clamped): far inside the message limits of both sides.
  std::uint32_t max_export_chunk = 4u << 20;
  // Where the server's log lines go (syslog priority: 3 error … 7 debug).
  std::function<void(int priority, const std::string& line)> log;
};

struct ServerCounters {
  std::uint64_t connections = 0;       // accepted so far
  std::uint64_t refused = 0;           // over max_clients
  std::uint64_t evicted = 0;           // silent connections closed for a newcomer
  std::uint64_t limits_hit = 0;        // clients disconnected over a limit
  std::uint64_t disconnected = 0;
  std::uint64_t frames = 0;            // delta frames sent (keep-alives included)
  std::uint64_t keepalives = 0;
  std::uint64_t keyframes = 0;
  std::uint64_t bytes_sent = 0;        // stream payloads (keyframes and frames)
};

class Server {
 public:
  Server(kj::AsyncIoContext& io, DaemonControl& control, ServerOptions options = {});
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // The scene being streamed; every viewer gets a new keyframe. `state`
  // must stay alive until the next set_scene (or the server's end). A
  // reader of `state` may come built (a big scene's takes a while to fill:
  // the daemon builds it off the io loop); what it replaced is returned, for
  // the caller to free where it likes.
  struct Replaced {
    SceneInfo info;
    std::unique_ptr<PublishedReader> reader;
  };
  Replaced set_scene(SceneInfo info, const PublishedState& state, std::unique_ptr<PublishedReader> reader = nullptr);
  // Which device slot drives each tool (-1: none), as devices come and go.
  void set_tool_devices(const std::vector<std::int32_t>& slot_of_tool);
  // Accepts clients on a listening socket (takes ownership of the fd).
  void listen(int fd);
  // Serves one connected stream (the listener's accepts; tests; the fuzzer).
  void serve(kj::Own<kj::AsyncIoStream> stream, std::string peer);

  // Reads the latest published state and sends what is due (the pump timer
  // calls it; tests may too).
  void pump();
  // Stops the pump and drops every client (before the published state goes away).
  void close();

  std::size_t clients() const { return clients_.size(); }
  std::size_t viewers() const { return streams_.size(); }
  std::size_t exports() const { return exports_.size(); }   // being written or held
  const ServerCounters& counters() const { return counters_; }

  // For the Session implementation (interfaces.cpp).
  struct Stream;
  struct Client;
  DaemonControl& control() { return control_; }
  void fill_status(proto::Stats::Builder out);
  void fill_keyframe_now(proto::Keyframe::Builder out);
  // A message big enough for the loaded scene's keyframe: built in one
  // allocation, not a dozen growing ones (each zeroed).
  capnp::MessageSize keyframe_size_hint() const { return {keyframe_bytes_ / sizeof(capnp::word) + 1024, 0}; }
  std::uint64_t add_stream(proto::Viewer::Client viewer, float tolerance, float fps, std::uint64_t client);
  void remove_stream(std::uint64_t id);
  void set_rate(std::uint64_t id, float fps);
  void set_tolerance(std::uint64_t id, float tolerance);
  void said_hello(std::uint64_t client, const std::string& name);
  // Whether a call of this client is answered: false once it is over its
  // queue limit (it is then disconnected at the next turn of the loop).
  bool admit(std::uint64_t client);
  // The hello of a connection served only to be refused: its answer ("" for the others).
  std::string refusal(std::uint64_t client) const;
  // Resolves true once the sim thread reports `paused`, false after `tries` ms.
  kj::Promise<bool> until_paused(bool paused, int tries = 2000);
  // Undo (redo = false) or redo `count` strokes for a client, once
  // history_move_refusal has said nothing against it ("": go ahead; else the
  // answer: the count out of range, too many such calls in flight). A
  // failure of the daemon's promise becomes an outcome with its error.
  std::string history_move_refusal(std::uint64_t client, std::uint32_t count) const;
  kj::Promise<HistoryMoveOutcome> move_history(std::uint64_t client, bool redo, std::uint32_t count);
  void fill_history(proto::History::Builder out, std::uint32_t from, std::uint32_t limit);
  // An export for a client, once export_refusal has said nothing against it
  // (too many exports). start_export takes a place for it, asks the daemon
  // and resolves when the daemon has answered; open_export then gives "" and
  // the size, the export now held by a reader (make_export_reader), or the
  // daemon's error. release_export must follow whatever happened (also a
  // cancelled call): it gives the place back unless a reader holds it. The
  // daemon's answer is taken by the server, not the call, so an export keeps
  // its place while the daemon writes it, also after its client has gone
  // (whose file is then closed as it lands).
  std::string export_refusal(std::uint64_t client) const;
  kj::Promise<void> start_export(std::uint64_t client, std::uint64_t& id);
  std::string open_export(std::uint64_t id, std::uint64_t& size);
  void release_export(std::uint64_t id);
  // ExportReader (interfaces.cpp): `count` bytes (clamped) at `offset` of
  // export `id` into `out`; a bad offset, an expired export or a failed
  // read throws (the call fails with the reason).
  void read_export(std::uint64_t id, std::uint64_t offset, std::uint32_t count,
                   proto::ExportReader::ReadResults::Builder out);
  void close_export(std::uint64_t id);
  const ServerOptions& options() const { return options_; }

 private:
  class Errors : public kj::TaskSet::ErrorHandler {
   public:
    void taskFailed(kj::Exception&& e) override;
  };
  kj::Promise<void> accept_loop();
  // A connection, served (`refusal` non-empty: its hello is answered with
  // that and it is closed after).
  void serve_client(kj::Own<kj::AsyncIoStream> stream, std::string peer, std::string refusal, int fd);
  // Forgets connections without a hello whose peer has closed already.
  void sweep_closed();
  // Closes a client over a limit, with the log line.
  void drop(std::uint64_t id, const std::string& why);
  // The oldest connection without a hello that connected before the given
  // time (CLOCK_MONOTONIC ns), or 0.
  std::uint64_t oldest_silent(std::int64_t connected_before_ns) const;
  void check_queues();
  std::uint64_t max_queued_bytes() const;
  kj::Promise<void> pump_loop();
  kj::Promise<void> track_send(std::uint64_t id, kj::Promise<void> sent);
  DaemonStatus status_now();
  // Closes export readers not read for export_idle_timeout.
  void expire_exports(std::int64_t now);
  // The daemon's answer to export `id` (an fd of -1: none); closes the fd when
  // the export is gone.
  void land_export(std::uint64_t id, std::string error, int fd, std::uint64_t bytes);
  void send_keyframe(Stream& s);
  bool send_frame(Stream& s, std::int64_t now);

  kj::AsyncIoContext& io_;
  DaemonControl& control_;
  ServerOptions options_;
  SceneInfo scene_;
  std::unique_ptr<PublishedReader> reader_;
  std::uint64_t receive_limit_words_ = 0;
  std::uint64_t keyframe_bytes_ = 0;         // of the loaded scene, about
  int listen_fd_ = -1;
  kj::Own<kj::UnixEventPort::FdObserver> listen_observer_;
  std::map<std::uint64_t, std::unique_ptr<Client>> clients_;
  std::map<std::uint64_t, std::unique_ptr<Stream>> streams_;
  struct Export;
  std::map<std::uint64_t, std::unique_ptr<Export>> exports_;
  std::uint64_t next_client_ = 1, next_stream_ = 1, next_export_ = 1;
  ServerCounters counters_;
  std::vector<std::vector<std::uint32_t>> scratch_;  // per body: indices of one frame
  std::int64_t refused_logged_ns_ = 0;
  bool closed_ = false;
  Errors errors_;
  kj::Own<kj::TaskSet> tasks_;   // last: accept and pump loops, client disconnects
};

// A viewer's maxFps as used: within [0.1, 1000], the fallback when not finite or ≤ 0.
float clamp_fps(float fps, float fallback);

}  // namespace sculpt::server
