// libFuzzer over the server's message handling: the input is what a client
// sends on its socket (capnp framing, RPC messages, our methods' params).
// The server serves it through an in-memory pipe exactly as it serves a
// socket, with the reader limits sculptd uses; whatever it is, the server
// must not crash, and must let the client go when it hangs up and close
// every export file it was given for it.
#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include <kj/async-io.h>

#include "server/server.hpp"
#include "sim/shapes.hpp"
#include "sim/world.hpp"

namespace {

using namespace sculpt;

class FakeControl final : public server::DaemonControl {
 public:
  server::DaemonStatus status() override {
    server::DaemonStatus d;
    d.stats.rate_hz = 1000;
    d.scene = "fuzz";
    return d;
  }
  std::vector<server::DeviceEntry> devices() override {
    server::DeviceEntry e;
    e.name = "pad";
    e.tools = {0};
    return {e};
  }
  kj::Promise<std::string> load_scene(const std::string& path) override { return "not here: " + path; }
  kj::Promise<std::string> reset() override { return std::string(); }
  std::string set_paused(bool p) override {
    paused = p;
    return {};
  }
  bool paused_now() override { return paused; }
  kj::Promise<server::HistoryMoveOutcome> undo(std::uint32_t count) override { return move_history(count); }
  kj::Promise<server::HistoryMoveOutcome> redo(std::uint32_t count) override { return move_history(count); }
  server::HapticsTuneOutcome tune_haptics(std::uint32_t slot, const server::HapticsTune&) override {
    server::HapticsTuneOutcome out;
    if (slot != 0) out.error = "no device on slot " + std::to_string(slot);
    return out;
  }
  server::History history(std::uint32_t from, std::uint32_t limit) override {
    server::History h;
    h.budget_bytes = 1 << 20;
    // Three strokes, paged as the daemon pages them: from stroke `from` (0: the newest `limit`).
    const std::uint32_t first = from != 0 ? from : (limit >= 3 ? 1 : 4 - limit);
    for (std::uint32_t i = std::max(first, 1u); i <= 3 && h.entries.size() < limit; ++i) {
      server::HistoryEntry e;
      e.number = i;
      e.mesh_name = "ball";
      e.tools = {0};
      e.undone = i == 3;
      h.entries.push_back(e);
    }
    h.total = 3;
    return h;
  }
  kj::Promise<server::ExportOutcome> export_sculpt() override {
    // A small file (the seeds read it in one chunk), a memfd like one the daemon could give.
    server::ExportOutcome o;
    o.fd = ::memfd_create("fuzz-export", MFD_CLOEXEC);
    if (o.fd < 0) {
      o.error = "memfd_create failed";
      return o;
    }
    static const char bytes[10240] = {'s', 'c', 'u', 'l', 'p', 't'};
    o.bytes = ::write(o.fd, bytes, sizeof bytes) == static_cast<ssize_t>(sizeof bytes) ? sizeof bytes : 0;
    if (o.bytes == 0) o.error = "write failed";
    return o;
  }
  bool paused = false;

 private:
  static kj::Promise<server::HistoryMoveOutcome> move_history(std::uint32_t count) {
    server::HistoryMoveOutcome o;
    if (count > 3) o.error = "nothing more to undo";
    else o.done = count;
    o.tick = 42;
    return o;
  }
};

struct Fixture {
  kj::AsyncIoContext io = kj::setupAsyncIo();
  FakeControl control;
  sim::World<float> world{sim::SimSettings{}, 1};
  std::unique_ptr<server::PublishedState> published;
  std::unique_ptr<server::Server> server;

  Fixture() {
    world.add_body(sim::make_icosphere(0.05f, 1), sim::Material{});
    published = std::make_unique<server::PublishedState>(world, 1000.0);
    server::ServerOptions o;
    o.pump_period = 1 * kj::MILLISECONDS;
    server = std::make_unique<server::Server>(io, control, o);
    server::SceneInfo info;
    info.scene = "fuzz";
    info.rate_hz = 1000;
    info.meshes.resize(1);
    info.tools.resize(1);
    (void)server->set_scene(info, *published);
  }
};

Fixture& fixture() {
  static Fixture* f = new Fixture();  // never destroyed: libFuzzer exits without unwinding
  return *f;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Fixture& f = fixture();
  auto pipe = f.io.provider->newTwoWayPipe();
  f.server->serve(kj::mv(pipe.ends[0]), "fuzz");
  auto client = kj::mv(pipe.ends[1]);
  // Drain whatever the server answers, so its writes never wait on us.
  auto buffer = kj::heapArray<kj::byte>(4096);
  kj::Function<kj::Promise<void>()> drain;
  drain = [&]() -> kj::Promise<void> {
    return client->tryRead(buffer.begin(), 1, buffer.size()).then([&](std::size_t n) -> kj::Promise<void> {
      if (n == 0) return kj::READY_NOW;
      return drain();
    });
  };
  auto reading = drain().eagerlyEvaluate([](kj::Exception&&) {});
  auto writing = client->write(data, size).then([&] { client->shutdownWrite(); }).eagerlyEvaluate([](kj::Exception&&) {});
  for (int i = 0; i < 200; ++i) f.io.waitScope.poll();
  // Hang up; the server must let the client go.
  writing = nullptr;
  reading = nullptr;
  client = nullptr;
  for (int i = 0; i < 200 && (f.server->clients() > 0 || f.server->exports() > 0); ++i) f.io.waitScope.poll();
  if (f.server->clients() != 0 || f.server->exports() != 0) std::abort();
  return 0;
}
