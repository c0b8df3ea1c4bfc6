#include "server/checked_stream.hpp"

#include <capnp/rpc.capnp.h>
#include <fmt/format.h>

namespace sculpt::server {
namespace {

// The capabilities a message carries: only calls and returns have a payload
// with a capability table.
std::size_t capabilities_in(capnp::MessageReader& reader) {
  const auto m = reader.getRoot<capnp::rpc::Message>();
  switch (m.which()) {
    case capnp::rpc::Message::CALL: return m.getCall().getParams().getCapTable().size();
    case capnp::rpc::Message::RETURN: {
      const auto r = m.getReturn();
      return r.isResults() ? r.getResults().getCapTable().size() : 0;
    }
    default: return 0;
  }
}

}  // namespace

kj::Promise<kj::Maybe<capnp::MessageReaderAndFds>> CheckedMessageStream::tryReadMessage(
    kj::ArrayPtr<kj::AutoCloseFd> fds, capnp::ReaderOptions, kj::ArrayPtr<capnp::word> scratch) {
  // The read itself refuses a message whose segments add up to more words
  // than the traversal limit ("Message is too large").
  capnp::ReaderOptions mine;
  mine.traversalLimitInWords = limits_.max_bytes / sizeof(capnp::word);
  mine.nestingLimit = limits_.nesting;
  // Through the timer, i.e. through epoll: a client whose calls are already
  // buffered (pipelined by the thousand) would otherwise have them all
  // handled, each answer a keyframe, before the event loop looks at any
  // other client's socket again (kj polls for I/O only when no event is ready).
  return timer_.afterDelay(0 * kj::NANOSECONDS)
      .then([this, fds, mine, scratch] { return inner_.tryReadMessage(fds, mine, scratch); })
      .then(
          [this](kj::Maybe<capnp::MessageReaderAndFds>&& got) -> kj::Maybe<capnp::MessageReaderAndFds> {
            KJ_IF_MAYBE(m, got) {
              const std::size_t caps = capabilities_in(*m->reader);
              if (caps > limits_.max_capabilities) {
                violation_ = fmt::format("a message carried {} capabilities (limit: {} per message)", caps,
                                         limits_.max_capabilities);
                KJ_FAIL_REQUIRE("too many capabilities in one message", caps, limits_.max_capabilities);
              }
            }
            return kj::mv(got);
          },
          [this](kj::Exception&& e) -> kj::Maybe<capnp::MessageReaderAndFds> {
            if (violation_.empty() && e.getType() != kj::Exception::Type::DISCONNECTED)
              violation_ = fmt::format("a malformed or oversized message ({}; limits: {} bytes, nesting {})",
                                       e.getDescription().cStr(), limits_.max_bytes, limits_.nesting);
            kj::throwFatalException(kj::mv(e));
          });
}

}  // namespace sculpt::server
