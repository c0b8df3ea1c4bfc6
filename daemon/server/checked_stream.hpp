// What one client may send in one message, checked before the RPC system
// acts on it. Cap'n Proto's receive limit is also its send limit (it refuses
// to send a message it could not receive), and the daemon sends keyframes of
// whole scenes; so the size of what a client sends is limited here instead,
// and so is the number of capabilities a message carries (each one the RPC
// system imports costs memory: a 16 MB hello holding a million of them took
// a gigabyte). A message over a limit ends the connection; `violation` says
// which limit, for the server's log line. Each message is read after a pass
// through the event loop's I/O poll, so one client's pipelined calls never
// hold up the others.
#pragma once

#include <cstdint>
#include <string>

#include <capnp/serialize-async.h>
#include <kj/async-io.h>
#include <kj/timer.h>

namespace sculpt::server {

struct MessageLimits {
  std::uint64_t max_bytes = 1 << 20;   // one incoming message, framing included
  unsigned max_capabilities = 8;       // in one message's capability table
  int nesting = 16;
};

class CheckedMessageStream final : public capnp::MessageStream {
 public:
  CheckedMessageStream(kj::AsyncIoStream& stream, kj::Timer& timer, MessageLimits limits, std::string& violation)
      : inner_(stream), timer_(timer), limits_(limits), violation_(violation) {}

  kj::Promise<kj::Maybe<capnp::MessageReaderAndFds>> tryReadMessage(kj::ArrayPtr<kj::AutoCloseFd> fds,
                                                                    capnp::ReaderOptions options,
                                                                    kj::ArrayPtr<capnp::word> scratch) override;
  kj::Promise<void> writeMessage(kj::ArrayPtr<const int> fds,
                                 kj::ArrayPtr<const kj::ArrayPtr<const capnp::word>> segments) override {
    return inner_.writeMessage(fds, segments);
  }
  kj::Promise<void> writeMessages(kj::ArrayPtr<kj::ArrayPtr<const kj::ArrayPtr<const capnp::word>>> messages) override {
    return inner_.writeMessages(messages);
  }
  kj::Maybe<int> getSendBufferSize() override { return inner_.getSendBufferSize(); }
  kj::Promise<void> end() override { return inner_.end(); }

 private:
  capnp::AsyncIoMessageStream inner_;
  kj::Timer& timer_;
  MessageLimits limits_;
  std::string& violation_;
};

}  // namespace sculpt::server
