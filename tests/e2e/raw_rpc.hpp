// Cap'n Proto RPC messages written by hand on a raw connection: what a client
// that breaks the rules sends (calls whose answers it never reads,
// capabilities by the thousand), built from rpc.capnp and the daemon's schema.
#pragma once

#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <string>

#include <capnp/message.h>
#include <capnp/rpc.capnp.h>
#include <capnp/schema.h>
#include <capnp/serialize.h>

#include "daemon_fixture.hpp"
#include "sculpt.capnp.h"

namespace sculpt::e2e {

class RawRpc {
 public:
  explicit RawRpc(const std::string& socket) : fd_(connect_raw(socket)) {}
  ~RawRpc() {
    if (fd_ >= 0) ::close(fd_);
  }
  RawRpc(const RawRpc&) = delete;
  RawRpc& operator=(const RawRpc&) = delete;

  bool connected() const { return fd_ >= 0; }

  // Bootstrap (question 0), then hello on it (question 1) carrying `caps`
  // capabilities in its table. False when the write failed (closed).
  bool hello(std::uint32_t caps = 0) {
    {
      capnp::MallocMessageBuilder m;
      m.initRoot<capnp::rpc::Message>().initBootstrap().setQuestionId(0);
      if (!send(m)) return false;
    }
    capnp::MallocMessageBuilder m;
    auto call = m.initRoot<capnp::rpc::Message>().initCall();
    call.setQuestionId(1);
    call.initTarget().initPromisedAnswer().setQuestionId(0);
    call.setInterfaceId(capnp::typeId<proto::Sculptd>());
    call.setMethodId(0);
    auto params = call.initParams();
    auto hello = params.getContent().initAs<proto::Sculptd::HelloParams>();
    hello.setMajor(proto::PROTOCOL_MAJOR);
    hello.setMinor(proto::PROTOCOL_MINOR);
    hello.setClient("raw-rpc-test");
    if (caps > 0) {
      auto table = params.initCapTable(caps);
      for (std::uint32_t i = 0; i < caps; ++i) table[i].setSenderHosted(i);
    }
    return send(m);
  }

  // session.keyframe(), pipelined on hello's answer, as question `q` (> 1).
  bool keyframe(std::uint32_t q) {
    capnp::MallocMessageBuilder m;
    auto call = m.initRoot<capnp::rpc::Message>().initCall();
    call.setQuestionId(q);
    auto answer = call.initTarget().initPromisedAnswer();
    answer.setQuestionId(1);
    answer.initTransform(1)[0].setGetPointerField(session_field());
    call.setInterfaceId(capnp::typeId<proto::Session>());
    call.setMethodId(2);
    call.initParams().getContent().initAs<proto::Session::KeyframeParams>();
    return send(m);
  }

  bool send(capnp::MessageBuilder& m) {
    const auto words = capnp::messageToFlatArray(m);
    const auto bytes = words.asBytes();
    return fd_ >= 0 && write_all(fd_, bytes.begin(), bytes.size());
  }

  // Reads and discards until the daemon closes the connection; true if it
  // did within `timeout`.
  bool closed_within(std::chrono::milliseconds timeout) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    char buf[65536];
    while (std::chrono::steady_clock::now() < end) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 50) <= 0) continue;
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n == 0 || (n < 0 && errno != EINTR && errno != EAGAIN)) return true;
    }
    return false;
  }

 private:
  // Where hello's results keep `session` (a pointer field).
  static std::uint16_t session_field() {
    return static_cast<std::uint16_t>(capnp::Schema::from<proto::Sculptd::HelloResults>()
                                          .getFieldByName("session")
                                          .getProto()
                                          .getSlot()
                                          .getOffset());
  }

  int fd_ = -1;
};

}  // namespace sculpt::e2e
