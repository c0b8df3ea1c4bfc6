// The server's undo, redo, history and export (protocol 1.5) and haptics
// tuning (1.6) against a fake
// daemon (fake_control.hpp), spoken to through in-memory pipes exactly as a
// client on the socket would: what reaches the daemon, what comes back, the
// limits (counts, calls in flight, exports open per connection and in all,
// idle readers) and that every export file is closed once nobody can read it.
#include <chrono>
#include <cstring>
#include <limits>
#include <optional>
#include <memory>
#include <string>

#include <capnp/rpc-twoparty.h>
#include <gtest/gtest.h>

#include "fake_control.hpp"

namespace sculpt::test {
namespace {

// One client connection to the harness's server.
struct Client {
  kj::Own<kj::AsyncIoStream> stream;
  kj::Own<capnp::TwoPartyClient> rpc;
  proto::Session::Client session = nullptr;
  std::uint16_t minor = 0;

  explicit Client(Harness& h) {
    auto pipe = h.io.provider->newTwoWayPipe();
    h.server->serve(kj::mv(pipe.ends[0]), "session-test");
    stream = kj::mv(pipe.ends[1]);
    rpc = kj::heap<capnp::TwoPartyClient>(*stream);
    auto req = rpc->bootstrap().castAs<proto::Sculptd>().helloRequest();
    req.setMajor(proto::PROTOCOL_MAJOR);
    req.setMinor(proto::PROTOCOL_MINOR);
    req.setClient("session-test");
    auto reply = req.send().wait(h.io.waitScope);
    minor = reply.getMinor();
    session = reply.getSession();
  }
};

// The description of the exception a call fails with ("" if it did not).
template <class Promise>
std::string failure(Promise&& p, kj::WaitScope& ws) {
  try {
    p.wait(ws);
  } catch (const kj::Exception& e) {
    return e.getDescription().cStr();
  }
  return {};
}

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

struct HistoryMove {
  bool ok;
  std::string error;
  std::uint32_t done;
  std::uint64_t tick;
};

template <class Reply>
HistoryMove history_move_of(Reply r) {
  return {r.getResult().getOk(), r.getResult().getError().cStr(), r.getDone(), r.getTick()};
}

HistoryMove undo(Client& c, Harness& h, std::uint32_t count) {
  auto req = c.session.undoRequest();
  req.setCount(count);
  return history_move_of(req.send().wait(h.io.waitScope));
}

HistoryMove redo(Client& c, Harness& h, std::uint32_t count) {
  auto req = c.session.redoRequest();
  req.setCount(count);
  return history_move_of(req.send().wait(h.io.waitScope));
}

struct Opened {
  bool ok = false;
  std::string error;
  std::uint64_t size = 0;
  proto::ExportReader::Client reader = nullptr;
};

Opened opened(capnp::Response<proto::Session::ExportSculptResults>&& r) {
  Opened o;
  o.ok = r.getResult().getOk();
  o.error = r.getResult().getError();
  o.size = r.getSize();
  if (o.ok) o.reader = r.getReader();
  return o;
}

Opened open_export(Client& c, Harness& h) { return opened(c.session.exportSculptRequest().send().wait(h.io.waitScope)); }

std::string read_chunk(proto::ExportReader::Client& reader, Harness& h, std::uint64_t offset, std::uint32_t count) {
  auto req = reader.readRequest();
  req.setOffset(offset);
  req.setCount(count);
  auto r = req.send().wait(h.io.waitScope);
  const auto d = r.getData();
  return std::string(reinterpret_cast<const char*>(d.begin()), d.size());
}

TEST(Session, TheHelloSaysTheMinorTheServerSpeaks) {
  Harness h;
  Client c(h);
  EXPECT_EQ(c.minor, proto::PROTOCOL_MINOR);
  EXPECT_GE(proto::PROTOCOL_MINOR, 6);
}

TEST(Undo, TheCountReachesTheDaemonAndItsOutcomeComesBack) {
  Harness h;
  Client c(h);
  h.control.history_move_outcome = {"", 0, 12345};
  HistoryMove e = undo(c, h, 3);
  EXPECT_TRUE(e.ok) << e.error;
  EXPECT_EQ(e.error, "");
  EXPECT_EQ(e.done, 3u);
  EXPECT_EQ(e.tick, 12345u);
  e = redo(c, h, 2);
  EXPECT_TRUE(e.ok) << e.error;
  EXPECT_EQ(e.done, 2u);
  EXPECT_EQ(h.control.undo_counts, std::vector<std::uint32_t>{3});
  EXPECT_EQ(h.control.redo_counts, std::vector<std::uint32_t>{2});
  // Fewer done than asked is the daemon's to say.
  h.control.history_move_outcome = {"", 1, 12400};
  e = undo(c, h, 5);
  EXPECT_TRUE(e.ok);
  EXPECT_EQ(e.done, 1u);
}

TEST(Undo, TheDaemonsRefusalIsTheResultsError) {
  Harness h;
  Client c(h);
  h.control.history_move_outcome = {"nothing to undo", 0, 0};
  HistoryMove e = undo(c, h, 1);
  EXPECT_FALSE(e.ok);
  EXPECT_EQ(e.error, "nothing to undo");
  h.control.history_move_outcome = {"stroke 4 was made before a scene reload at tick 9000", 0, 0};
  e = redo(c, h, 1);
  EXPECT_FALSE(e.ok);
  EXPECT_EQ(e.error, "stroke 4 was made before a scene reload at tick 9000");
}

TEST(Undo, CountsOutsideOneToTheLimitAreRefusedWithoutAskingTheDaemon) {
  Harness h;
  Client c(h);
  for (const std::uint32_t bad : {0u, 10001u, 4294967295u}) {
    HistoryMove e = undo(c, h, bad);
    EXPECT_FALSE(e.ok) << bad;
    EXPECT_TRUE(has(e.error, "count " + std::to_string(bad))) << e.error;
    EXPECT_TRUE(has(e.error, "1 to 10000")) << e.error;
    e = redo(c, h, bad);
    EXPECT_FALSE(e.ok) << bad;
  }
  EXPECT_TRUE(h.control.undo_counts.empty());
  EXPECT_TRUE(h.control.redo_counts.empty());
  EXPECT_TRUE(undo(c, h, 10000).ok);
  EXPECT_TRUE(undo(c, h, 1).ok);
  EXPECT_EQ(h.control.undo_counts, (std::vector<std::uint32_t>{10000, 1}));
}

TEST(Undo, ABrokenDaemonPromiseIsAnErrorResultNotAFailedCall) {
  Harness h;
  Client c(h);
  h.control.history_moves_throw = true;
  const HistoryMove e = undo(c, h, 1);
  EXPECT_FALSE(e.ok);
  EXPECT_TRUE(has(e.error, "the daemon's undo failed")) << e.error;
  EXPECT_TRUE(has(e.error, "the sim thread is gone")) << e.error;
  h.control.history_moves_throw = false;
  EXPECT_TRUE(undo(c, h, 1).ok) << "the connection must still serve";
}

TEST(Undo, CallsBeingAppliedAreBoundedPerConnection) {
  Harness h;
  Client a(h), b(h);
  h.control.hold_history_moves = true;
  std::vector<kj::Promise<capnp::Response<proto::Session::UndoResults>>> held;
  for (int i = 0; i < 4; ++i) {
    auto req = a.session.undoRequest();
    req.setCount(1);
    held.push_back(req.send());
  }
  h.turn();
  ASSERT_EQ(h.control.held_history_moves.size(), 4u);
  HistoryMove e = undo(a, h, 1);
  EXPECT_FALSE(e.ok);
  EXPECT_TRUE(has(e.error, "max_pending_history_moves_per_client")) << e.error;
  EXPECT_EQ(h.control.undo_counts.size(), 4u) << "the refused call reached the daemon";
  // Another connection is not held up by this one's.
  auto other = b.session.redoRequest();
  other.setCount(2);
  auto other_reply = other.send();
  h.turn();
  EXPECT_EQ(h.control.redo_counts.size(), 1u);
  // One answered: a place is free again.
  h.control.release_history_move();
  EXPECT_TRUE(history_move_of(held[0].wait(h.io.waitScope)).ok);
  auto again = a.session.undoRequest();
  again.setCount(1);
  auto again_reply = again.send();
  h.turn();
  EXPECT_EQ(h.control.undo_counts.size(), 5u);
  while (!h.control.held_history_moves.empty()) h.control.release_history_move();
  for (std::size_t i = 1; i < held.size(); ++i) EXPECT_TRUE(history_move_of(held[i].wait(h.io.waitScope)).ok);
  EXPECT_TRUE(history_move_of(other_reply.wait(h.io.waitScope)).ok);
  EXPECT_TRUE(history_move_of(again_reply.wait(h.io.waitScope)).ok);
}

struct Tuned {
  bool ok;
  std::string error;
  float gain, limit;
};

Tuned tune(Client& c, Harness& h, std::uint32_t slot, std::optional<float> gain, std::optional<float> limit) {
  auto req = c.session.tuneHapticsRequest();
  req.setSlot(slot);
  req.setSetGain(gain.has_value());
  req.setGain(gain.value_or(0));
  req.setSetLimit(limit.has_value());
  req.setLimit(limit.value_or(0));
  auto r = req.send().wait(h.io.waitScope);
  return {r.getResult().getOk(), r.getResult().getError().cStr(), r.getGain(), r.getLimit()};
}

TEST(TuneHaptics, OnlyWhatIsSetChangesAndTheReplyHasBoth) {
  Harness h;
  Client c(h);
  Tuned t = tune(c, h, 0, 0.5f, std::nullopt);
  EXPECT_TRUE(t.ok) << t.error;
  EXPECT_FLOAT_EQ(t.gain, 0.5f);
  EXPECT_FLOAT_EQ(t.limit, 1.0f);
  t = tune(c, h, 0, std::nullopt, 0.25f);
  EXPECT_TRUE(t.ok) << t.error;
  EXPECT_FLOAT_EQ(t.gain, 0.5f);
  EXPECT_FLOAT_EQ(t.limit, 0.25f);
}

TEST(TuneHaptics, TheDaemonsRefusalIsTheResultsErrorAndNothingChanges) {
  Harness h;
  Client c(h);
  Tuned t = tune(c, h, 3, 0.5f, std::nullopt);
  EXPECT_FALSE(t.ok);
  EXPECT_TRUE(has(t.error, "slot 3")) << t.error;
  t = tune(c, h, 0, std::numeric_limits<float>::quiet_NaN(), std::nullopt);
  EXPECT_FALSE(t.ok);
  EXPECT_TRUE(has(t.error, "gain")) << t.error;
  EXPECT_FLOAT_EQ(t.gain, 1.0f);
  EXPECT_EQ(h.control.tuning.gain, 1.0);
}

TEST(SessionHistory, EveryFieldOldestFirstWithTheBudget) {
  Harness h;
  Client c(h);
  h.control.history_now = sample_history();
  auto r = c.session.historyRequest().send().wait(h.io.waitScope);
  const auto hist = r.getHistory();
  EXPECT_EQ(hist.getBudgetBytes(), 256u << 20);
  EXPECT_EQ(hist.getUsedBytes(), 3u * 18432);
  EXPECT_EQ(hist.getDropped(), 6u);
  EXPECT_EQ(hist.getOmitted(), 0u);
  ASSERT_EQ(hist.getEntries().size(), 3u);
  for (unsigned i = 0; i < 3; ++i) {
    const auto e = hist.getEntries()[i];
    const server::HistoryEntry& want = h.control.history_now.entries[i];
    EXPECT_EQ(e.getNumber(), want.number);
    EXPECT_EQ(e.getMesh(), want.mesh);
    EXPECT_EQ(std::string(e.getMeshName().cStr()), want.mesh_name);
    ASSERT_EQ(e.getTools().size(), want.tools.size());
    for (unsigned t = 0; t < want.tools.size(); ++t) EXPECT_EQ(e.getTools()[t], want.tools[t]);
    EXPECT_EQ(e.getFirstTick(), want.first_tick);
    EXPECT_EQ(e.getEndTick(), want.end_tick);
    EXPECT_EQ(e.getVertices(), want.vertices);
    EXPECT_EQ(e.getBytes(), want.bytes);
    EXPECT_EQ(e.getUndone(), want.undone);
  }
  h.control.history_now = {};
  auto empty = c.session.historyRequest().send().wait(h.io.waitScope);
  EXPECT_EQ(empty.getHistory().getEntries().size(), 0u);
}

TEST(SessionHistory, PastTheLimitOnlyTheNewestAreSentAndTheRestCounted) {
  server::ServerOptions o;
  o.max_history_entries = 2;
  Harness h(o);
  Client c(h);
  h.control.history_now = sample_history();
  auto r = c.session.historyRequest().send().wait(h.io.waitScope);
  const auto hist = r.getHistory();
  ASSERT_EQ(hist.getEntries().size(), 2u);
  EXPECT_EQ(hist.getEntries()[0].getNumber(), 8u);
  EXPECT_EQ(hist.getEntries()[1].getNumber(), 9u);
  EXPECT_EQ(hist.getOmitted(), 1u);
}

TEST(SessionHistory, APageIsAskedOfTheControlAndTheRestCountedOnBothSides) {
  server::ServerOptions o;
  o.max_history_entries = 2;
  Harness h(o);
  Client c(h);
  h.control.history_now = sample_history();  // strokes 7, 8, 9
  auto req = c.session.historyRequest();
  req.setFrom(8);
  req.setLimit(1);
  auto r = req.send().wait(h.io.waitScope);
  const auto hist = r.getHistory();
  ASSERT_EQ(hist.getEntries().size(), 1u);
  EXPECT_EQ(hist.getEntries()[0].getNumber(), 8u);
  EXPECT_EQ(hist.getOmitted(), 1u);
  EXPECT_EQ(hist.getNewer(), 1u);
  EXPECT_EQ(hist.getTotal(), 3u);
  // A limit past the server's is the server's; none (an older client) too.
  auto big = c.session.historyRequest();
  big.setFrom(7);
  big.setLimit(1000000);
  auto whole = big.send().wait(h.io.waitScope);
  ASSERT_EQ(whole.getHistory().getEntries().size(), 2u);
  EXPECT_EQ(whole.getHistory().getEntries()[0].getNumber(), 7u);
  EXPECT_EQ(whole.getHistory().getNewer(), 1u);
  c.session.historyRequest().send().wait(h.io.waitScope);
  const std::vector<std::pair<std::uint32_t, std::uint32_t>> asked{{8, 1}, {7, 2}, {0, 2}};
  EXPECT_EQ(h.control.history_asks, asked) << "the control is asked for the page, never for more";
}

TEST(SessionExport, ReadInChunksOfAtMostTheLimitThenEmptyAtTheEnd) {
  Harness h;
  Client c(h);
  const std::size_t size = (std::size_t{10} << 20) + 123;
  h.control.export_bytes = export_pattern(size);
  Opened o = open_export(c, h);
  ASSERT_TRUE(o.ok) << o.error;
  EXPECT_EQ(o.size, size);
  EXPECT_EQ(open_export_files(), 1);
  // A huge count is clamped to 4 MiB.
  std::string got = read_chunk(o.reader, h, 0, 0xffffffffu);
  EXPECT_EQ(got.size(), 4u << 20);
  while (got.size() < size) {
    const std::string chunk = read_chunk(o.reader, h, got.size(), 4u << 20);
    ASSERT_FALSE(chunk.empty()) << "ended early at " << got.size();
    got += chunk;
  }
  EXPECT_EQ(got.size(), size);
  EXPECT_TRUE(got == h.control.export_bytes) << "the bytes differ";
  EXPECT_EQ(read_chunk(o.reader, h, size, 100), "") << "at the end: no data";
  EXPECT_EQ(read_chunk(o.reader, h, size - 3, 100), h.control.export_bytes.substr(size - 3)) << "the last bytes";
  EXPECT_EQ(read_chunk(o.reader, h, 17, 0), "");
  EXPECT_EQ(read_chunk(o.reader, h, 1000, 5), h.control.export_bytes.substr(1000, 5)) << "any offset, in any order";
}

TEST(SessionExport, AnOffsetPastTheEndFailsNamingItAndTheReaderStillServes) {
  Harness h;
  Client c(h);
  h.control.export_bytes = export_pattern(1000);
  Opened o = open_export(c, h);
  ASSERT_TRUE(o.ok) << o.error;
  for (const std::uint64_t bad : {std::uint64_t{1001}, std::uint64_t{1} << 62, ~std::uint64_t{0}}) {
    auto req = o.reader.readRequest();
    req.setOffset(bad);
    req.setCount(10);
    const std::string why = failure(req.send(), h.io.waitScope);
    EXPECT_TRUE(has(why, "offset " + std::to_string(bad))) << why;
    EXPECT_TRUE(has(why, "1000 bytes")) << why;
  }
  EXPECT_EQ(read_chunk(o.reader, h, 990, 100), h.control.export_bytes.substr(990));
}

TEST(SessionExport, DroppingTheReaderClosesTheFile) {
  Harness h;
  Client c(h);
  {
    Opened o = open_export(c, h);
    ASSERT_TRUE(o.ok) << o.error;
    EXPECT_EQ(open_export_files(), 1);
    EXPECT_EQ(h.server->exports(), 1u);
  }
  h.turn();
  EXPECT_EQ(open_export_files(), 0);
  EXPECT_EQ(h.server->exports(), 0u);
  // An answer nobody takes the reader from closes it too.
  c.session.exportSculptRequest().send().wait(h.io.waitScope);
  h.turn();
  EXPECT_EQ(open_export_files(), 0);
  EXPECT_EQ(h.server->exports(), 0u);
}

TEST(SessionExport, ADisconnectClosesTheClientsFiles) {
  Harness h;
  auto c = std::make_unique<Client>(h);
  Opened a = open_export(*c, h), b = open_export(*c, h);
  ASSERT_TRUE(a.ok && b.ok);
  EXPECT_EQ(open_export_files(), 2);
  a = {};
  b = {};
  c.reset();
  h.turn();
  EXPECT_EQ(h.server->clients(), 0u);
  EXPECT_EQ(open_export_files(), 0);
  EXPECT_EQ(h.server->exports(), 0u);
}

TEST(SessionExport, ReadersArePerConnectionAndOverallBounded) {
  server::ServerOptions opt;
  opt.max_exports = 3;
  Harness h(opt);
  Client a(h), b(h);
  Opened a1 = open_export(a, h), a2 = open_export(a, h);
  ASSERT_TRUE(a1.ok && a2.ok);
  Opened a3 = open_export(a, h);
  EXPECT_FALSE(a3.ok);
  EXPECT_TRUE(has(a3.error, "max_exports_per_client")) << a3.error;
  EXPECT_EQ(h.control.exports_asked, 2) << "a refused export reached the daemon";
  Opened b1 = open_export(b, h);
  ASSERT_TRUE(b1.ok) << b1.error;
  Opened b2 = open_export(b, h);
  EXPECT_FALSE(b2.ok);
  EXPECT_TRUE(has(b2.error, "max_exports)")) << b2.error;
  EXPECT_EQ(open_export_files(), 3);
  // Dropping one gives its place back.
  a1 = {};
  h.turn();
  b2 = open_export(b, h);
  EXPECT_TRUE(b2.ok) << b2.error;
  EXPECT_EQ(open_export_files(), 3);
}

TEST(SessionExport, ExportsBeingWrittenCountUntilTheDaemonAnswersAndOneWithoutAClientIsClosed) {
  server::ServerOptions opt;
  opt.max_exports_per_client = 1;
  Harness h(opt);
  h.control.hold_exports = true;
  auto c = std::make_unique<Client>(h);
  auto pending = c->session.exportSculptRequest().send();
  h.turn();
  ASSERT_EQ(h.control.held_exports.size(), 1u);
  EXPECT_EQ(h.server->exports(), 1u);
  Opened second = open_export(*c, h);
  EXPECT_FALSE(second.ok);
  EXPECT_TRUE(has(second.error, "being written or held open")) << second.error;
  // The client goes while the daemon writes: the export keeps its place
  // (the daemon is still writing it) and the file it then gives is closed.
  pending = nullptr;
  c.reset();
  h.turn();
  EXPECT_EQ(h.server->clients(), 0u);
  EXPECT_EQ(h.server->exports(), 1u);
  h.control.release_export();
  h.turn();
  EXPECT_EQ(open_export_files(), 0);
  EXPECT_EQ(h.server->exports(), 0u);
  // A held export answered while the client waits is served.
  Client d(h);
  auto waiting = d.session.exportSculptRequest().send();
  h.turn();
  h.control.release_export();
  Opened o = opened(waiting.wait(h.io.waitScope));
  EXPECT_TRUE(o.ok) << o.error;
  EXPECT_EQ(read_chunk(o.reader, h, 0, 100), "sculpt");
}

TEST(SessionExport, AReaderNotReadForTheIdleTimeoutIsClosedAndItsReadsSaySo) {
  // On the real clock, so what is asserted holds however late this thread
  // runs: a reader read within the timeout stays open (its reads only fail
  // after a gap longer than it), and one that is not is closed, never before
  // the timeout.
  using Clock = std::chrono::steady_clock;
  constexpr auto kIdle = std::chrono::seconds(1);
  server::ServerOptions opt;
  opt.export_idle_timeout = 1 * kj::SECONDS;
  Harness h(opt);
  Client c(h);
  Opened o = open_export(c, h);
  ASSERT_TRUE(o.ok) << o.error;
  // Reads keep it open.
  auto last_read = Clock::now();
  for (int i = 0; i < 4; ++i) {
    h.io.provider->getTimer().afterDelay(50 * kj::MILLISECONDS).wait(h.io.waitScope);
    const auto sent = Clock::now();
    auto req = o.reader.readRequest();
    req.setCount(3);
    const std::string why = failure(req.send(), h.io.waitScope);
    if (!why.empty()) {
      // Only a gap past the timeout (this thread kept off its CPU) closes it.
      EXPECT_GT(Clock::now() - last_read, kIdle) << "closed while read: " << why;
      return;
    }
    last_read = sent;
  }
  last_read = Clock::now();
  EXPECT_EQ(read_chunk(o.reader, h, 0, 3), "scu");
  // Not read: closed once the timeout has passed (the server looks every
  // pump_period).
  const auto give_up = last_read + std::chrono::seconds(60);
  while (h.server->exports() != 0 && Clock::now() < give_up) {
    h.io.provider->getTimer().afterDelay(20 * kj::MILLISECONDS).wait(h.io.waitScope);
  }
  EXPECT_EQ(h.server->exports(), 0u);
  EXPECT_GE(Clock::now() - last_read, kIdle) << "closed before the idle timeout";
  EXPECT_EQ(open_export_files(), 0);
  auto req = o.reader.readRequest();
  req.setCount(3);
  const std::string why = failure(req.send(), h.io.waitScope);
  EXPECT_TRUE(has(why, "export_idle_timeout")) << why;
  EXPECT_TRUE(has(why, "after 1 s without a read")) << why;
  // Its place is free.
  EXPECT_TRUE(open_export(c, h).ok);
}

TEST(SessionExport, TheDaemonsErrorIsTheResultWithNoReaderAndNoFileLeftOpen) {
  Harness h;
  Client c(h);
  h.control.export_error = "the state directory is read-only";
  h.control.export_fd_with_error = true;
  Opened o = open_export(c, h);
  EXPECT_FALSE(o.ok);
  EXPECT_EQ(o.error, "the state directory is read-only");
  h.turn();
  EXPECT_EQ(open_export_files(), 0);
  EXPECT_EQ(h.server->exports(), 0u);
}

TEST(SessionExport, AFileThatIsNotWhatTheDaemonSaidIsRefusedAndClosed) {
  Harness h;
  Client c(h);
  h.control.reported_extra = 5;
  Opened o = open_export(c, h);
  EXPECT_FALSE(o.ok);
  EXPECT_TRUE(has(o.error, "reported 11 bytes, its file holds 6")) << o.error;
  h.turn();
  EXPECT_EQ(open_export_files(), 0);
  EXPECT_EQ(h.server->exports(), 0u);
}

TEST(SessionExport, AnEmptyExportHasSizeZeroAndReadsNothing) {
  Harness h;
  Client c(h);
  h.control.export_bytes.clear();
  Opened o = open_export(c, h);
  ASSERT_TRUE(o.ok) << o.error;
  EXPECT_EQ(o.size, 0u);
  EXPECT_EQ(read_chunk(o.reader, h, 0, 100), "");
}

}  // namespace
}  // namespace sculpt::test
