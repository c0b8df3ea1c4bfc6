// A client's connection to sculptd: connect to the Unix socket, say hello,
// get the Session (everything else goes through it).
//
//   auto io = kj::setupAsyncIo();
//   sculpt::client::Connection c(io, sculpt::client::resolve_socket_path(flag), "my-tool 1.0");
//   auto stats = c.session().statusRequest().send().wait(io.waitScope).getStats();
//
// Streaming: implement sculpt::proto::Viewer::Server (keyframe/frame, feed both
// to a MeshMirror), then
//   auto req = c.session().subscribeRequest();
//   req.setViewer(kj::heap<MyViewer>(...)); req.setToleranceM(1e-4f); req.setMaxFps(60);
//   auto sub = req.send().wait(io.waitScope).getSubscription();   // keep it: dropping it ends the stream
//   kj::NEVER_DONE.wait(io.waitScope);                            // or run your own loop
// The daemon calls your Viewer from the io loop; return from keyframe/frame
// when you have taken the data (the daemon sends the next frame only then,
// coalescing what changed meanwhile).
//
// Errors are ClientError with a kind: no_daemon ("no daemon is listening on
// PATH"), incompatible ("daemon speaks protocol N, this client M"), refused
// (any other refusal, with the daemon's reason) or failed (I/O, protocol).
#pragma once

#include <stdexcept>
#include <string>

#include <capnp/rpc-twoparty.h>
#include <kj/async-io.h>

#include "sculpt.capnp.h"

namespace sculpt::client {

class ClientError : public std::runtime_error {
 public:
  enum class Kind { no_daemon, incompatible, refused, failed };
  ClientError(Kind kind, const std::string& what) : std::runtime_error(what), kind_(kind) {}
  Kind kind() const { return kind_; }

 private:
  Kind kind_;
};

// Reader limits for what a client accepts from the daemon: keyframes of big
// scenes are large (50k vertices ≈ 2 MB), so far above capnp's 64 MiB default.
capnp::ReaderOptions client_reader_options();

class Connection {
 public:
  // Connects and says hello (major/minor: what this client speaks; tests
  // pass other values). Throws ClientError.
  Connection(kj::AsyncIoContext& io, const std::string& socket_path, const std::string& client_name,
             std::uint16_t major = proto::PROTOCOL_MAJOR, std::uint16_t minor = proto::PROTOCOL_MINOR);
  ~Connection();
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  proto::Session::Client& session() { return session_; }
  kj::WaitScope& wait_scope() { return io_.waitScope; }
  const std::string& socket_path() const { return path_; }
  const std::string& server() const { return server_; }       // the daemon's name and version
  std::uint16_t server_minor() const { return server_minor_; }
  // Fulfilled (or broken) when the daemon hangs up.
  kj::Promise<void> on_disconnect() { return network_->onDisconnect(); }

 private:
  kj::AsyncIoContext& io_;
  std::string path_;
  kj::Own<kj::AsyncIoStream> stream_;
  kj::Own<capnp::TwoPartyVatNetwork> network_;
  kj::Own<capnp::RpcSystem<capnp::rpc::twoparty::VatId>> rpc_;
  proto::Session::Client session_{nullptr};
  std::string server_;
  std::uint16_t server_minor_ = 0;
};

// Runs `f` and turns kj exceptions (a lost daemon, a broken promise) into a
// ClientError{failed} naming what was being done.
template <class F>
auto guarded(const char* what, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const kj::Exception& e) {
    throw ClientError(e.getType() == kj::Exception::Type::DISCONNECTED ? ClientError::Kind::no_daemon
                                                                        : ClientError::Kind::failed,
                      std::string(what) + ": " + e.getDescription().cStr());
  }
}

}  // namespace sculpt::client
