// A daemon for the server's tests: a server::DaemonControl whose answers the
// test sets (undo/redo outcomes, the history, export files as memfds), which
// records what it was asked and can hold its answers back; and a Harness:
// an io loop, a one-mesh published world and a Server serving that control.
// session_test.cpp speaks to it through in-memory pipes, sculptctl_test.cpp
// and fake_sculptd.cpp on a Unix socket.
#pragma once

#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <kj/async-io.h>

#include "server/server.hpp"
#include "sim/shapes.hpp"
#include "sim/world.hpp"

namespace sculpt::test {

// The name every export file of FakeControl has (/proc/self/fd shows "/memfd:NAME (deleted)").
inline constexpr const char* kExportFileName = "sculpt-export-test";

// Export files of FakeControl open in this process now.
inline int open_export_files() {
  int n = 0;
  for (const auto& e : std::filesystem::directory_iterator("/proc/self/fd")) {
    std::error_code ec;
    const std::string target = std::filesystem::read_symlink(e.path(), ec).string();
    if (!ec && target.rfind(std::string("/memfd:") + kExportFileName, 0) == 0) ++n;
  }
  return n;
}

// `size` bytes of a pattern no two nearby chunks share (byte i: a function of i).
inline std::string export_pattern(std::size_t size) {
  std::string s(size, '\0');
  for (std::size_t i = 0; i < size; ++i) s[i] = static_cast<char>((i * 7 + i / 4093) & 0xff);
  return s;
}

class FakeControl final : public server::DaemonControl {
 public:
  server::DaemonStatus status() override {
    server::DaemonStatus d;
    d.stats.rate_hz = 1000;
    d.scene = "fake";
    return d;
  }
  std::vector<server::DeviceEntry> devices() override { return {}; }
  kj::Promise<std::string> load_scene(const std::string& path) override { return "not here: " + path; }
  kj::Promise<std::string> reset() override { return std::string(); }
  std::string set_paused(bool p) override {
    paused = p;
    return {};
  }
  bool paused_now() override { return paused; }

  kj::Promise<server::HistoryMoveOutcome> undo(std::uint32_t count) override {
    undo_counts.push_back(count);
    return move_history(count);
  }
  kj::Promise<server::HistoryMoveOutcome> redo(std::uint32_t count) override {
    redo_counts.push_back(count);
    return move_history(count);
  }
  // history_now paged as the daemon pages it; what was asked is kept.
  server::History history(std::uint32_t from, std::uint32_t limit) override {
    history_asks.emplace_back(from, limit);
    server::History page = history_now;
    page.entries.clear();
    std::size_t first = 0;
    if (from == 0) {
      first = history_now.entries.size() > limit ? history_now.entries.size() - limit : 0;
    } else {
      while (first < history_now.entries.size() && history_now.entries[first].number < from) ++first;
    }
    for (std::size_t i = first; i < history_now.entries.size() && page.entries.size() < limit; ++i)
      page.entries.push_back(history_now.entries[i]);
    page.total = history_now.entries.size();
    page.older = first;
    page.newer = page.total - first - page.entries.size();
    return page;
  }
  std::vector<std::pair<std::uint32_t, std::uint32_t>> history_asks;  // (from, limit)
  // Slot 0 exists; values are checked as the daemon does.
  server::HapticsTuneOutcome tune_haptics(std::uint32_t slot, const server::HapticsTune& tune) override {
    server::HapticsTuneOutcome out;
    if (slot != 0) {
      out.error = "no device on slot " + std::to_string(slot);
      return out;
    }
    for (const auto& [name, v] : {std::pair{"gain", tune.gain}, std::pair{"limit", tune.limit}})
      if (v && !(*v >= 0 && *v <= 1)) out.error = std::string(name) + ": must be within [0, 1]";
    if (out.error.empty()) {
      if (tune.gain) tuning.gain = *tune.gain;
      if (tune.limit) tuning.limit = *tune.limit;
    }
    out.gain = tuning.gain;
    out.limit = tuning.limit;
    return out;
  }
  struct {
    double gain = 1.0, limit = 1.0;
  } tuning;
  kj::Promise<server::ExportOutcome> export_sculpt() override {
    ++exports_asked;
    if (!hold_exports) return make_export();
    auto paf = kj::newPromiseAndFulfiller<void>();
    held_exports.push_back(kj::mv(paf.fulfiller));
    return paf.promise.then([this] { return make_export(); });
  }

  // Answers the oldest held call (undo/redo: with history_move_outcome; export: a file).
  void release_history_move() {
    held_history_moves.front()->fulfill();
    held_history_moves.erase(held_history_moves.begin());
  }
  void release_export() {
    held_exports.front()->fulfill();
    held_exports.erase(held_exports.begin());
  }

  server::ExportOutcome make_export() {
    server::ExportOutcome o;
    o.error = export_error;
    if (export_error.empty() || export_fd_with_error) {
      o.fd = ::memfd_create(kExportFileName, MFD_CLOEXEC);
      if (o.fd < 0) throw std::runtime_error("memfd_create failed");
      for (std::size_t done = 0; done < export_bytes.size();) {
        const ssize_t n = ::write(o.fd, export_bytes.data() + done, export_bytes.size() - done);
        if (n <= 0) throw std::runtime_error("writing the export file failed");
        done += static_cast<std::size_t>(n);
      }
    }
    o.bytes = export_bytes.size() + reported_extra;
    return o;
  }

  // Set by the test.
  bool paused = false;
  server::HistoryMoveOutcome history_move_outcome{"", 1, 1000};
  bool history_moves_throw = false;    // the daemon's promise breaks
  bool hold_history_moves = false;     // answered only by release_history_move()
  server::History history_now;
  std::string export_bytes = "sculpt";
  std::string export_error;    // the daemon's refusal
  bool export_fd_with_error = false;  // ... with a file anyway (the server must close it)
  std::uint64_t reported_extra = 0;  // the daemon lies about the size by this much
  bool hold_exports = false;   // answered only by release_export()

  // What it was asked.
  std::vector<std::uint32_t> undo_counts, redo_counts;
  int exports_asked = 0;
  std::vector<kj::Own<kj::PromiseFulfiller<void>>> held_history_moves, held_exports;

 private:
  kj::Promise<server::HistoryMoveOutcome> move_history(std::uint32_t count) {
    if (history_moves_throw) return KJ_EXCEPTION(FAILED, "the sim thread is gone");
    if (!hold_history_moves) return answer(count);
    auto paf = kj::newPromiseAndFulfiller<void>();
    held_history_moves.push_back(kj::mv(paf.fulfiller));
    return paf.promise.then([this, count] { return answer(count); });
  }
  server::HistoryMoveOutcome answer(std::uint32_t count) const {
    server::HistoryMoveOutcome o = history_move_outcome;
    if (o.error.empty() && o.done == 0) o.done = count;
    return o;
  }
};

// An io loop, a one-mesh world's published state and a Server on FakeControl.
struct Harness {
  kj::AsyncIoContext io = kj::setupAsyncIo();
  FakeControl control;
  sim::World<float> world{sim::SimSettings{}, 1};
  std::unique_ptr<server::PublishedState> published;
  std::unique_ptr<server::Server> server;
  std::vector<std::string> log;

  explicit Harness(server::ServerOptions o = {}) {
    world.add_body(sim::make_icosphere(0.05f, 1), sim::Material{});
    published = std::make_unique<server::PublishedState>(world, 1000.0);
    o.log = [this](int, const std::string& line) { log.push_back(line); };
    server = std::make_unique<server::Server>(io, control, o);
    server::SceneInfo info;
    info.scene = "fake";
    info.rate_hz = 1000;
    info.meshes.resize(1);
    info.meshes[0].name = "ball";
    info.tools.resize(1);
    (void)server->set_scene(info, *published);
  }
  ~Harness() { server->close(); }

  // Turns of the event loop (the server's tasks, the pipes).
  void turn(int times = 50) {
    for (int i = 0; i < times; ++i) io.waitScope.poll();
  }
};

// A three-stroke history: strokes 7 and 8 on mesh 0 ("ball"), 9 (undone) on mesh 1 ("clay").
inline server::History sample_history() {
  server::History h;
  h.budget_bytes = 256u << 20;
  h.used_bytes = 3 * 18432;
  h.dropped = 6;
  for (std::uint32_t i = 0; i < 3; ++i) {
    server::HistoryEntry e;
    e.number = 7 + i;
    e.mesh = i == 2 ? 1 : 0;
    e.mesh_name = i == 2 ? "clay" : "ball";
    e.tools = i == 1 ? std::vector<std::uint32_t>{0, 1} : std::vector<std::uint32_t>{i};
    e.first_tick = 1000 * (i + 1);
    e.end_tick = 1000 * (i + 1) + 420;
    e.vertices = 1500 + i;
    e.bytes = 18432;
    e.undone = i == 2;
    h.entries.push_back(e);
  }
  return h;
}

}  // namespace sculpt::test
