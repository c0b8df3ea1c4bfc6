// The keeper's requests, the store thread's jobs and what its threads share
// (keeper/keeper.hpp): for the keeper's own files only (keeper.cpp, the
// thread files journal_thread.cpp, store_thread.cpp, replica_thread.cpp,
// snapshots.cpp and recovery.cpp).
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <kj/async.h>

#include "keeper/keeper.hpp"

namespace sculpt::daemon {

namespace keeper_detail {
using Clock = std::chrono::steady_clock;
// The journal and replica threads wait at most this long for work.
inline constexpr auto kIdleWait = std::chrono::milliseconds(10);
inline std::int64_t wall_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}
// The snapshot's meta format (snapshots.cpp writes it, recovery.cpp reads it).
inline constexpr int kMetaFormat = 1;
// The scene's files as a bundle, at most: its text (1 MiB at most) and its
// meshes. Recovery reads no larger one, so none is written.
inline constexpr std::uint64_t kMaxBundleBytes = std::uint64_t{256} << 20;
}  // namespace keeper_detail

struct Keeper::Request {
  enum class Kind { undo, redo, export_file };
  Kind kind = Kind::undo;
  std::uint32_t count = 0;
  // The result waits beside a void promise (as in host/worker.hpp): gcc 12
  // warns (-Wmaybe-uninitialized, a false positive) about any value inside
  // kj's cross-thread promise.
  std::shared_ptr<HistoryMoveResult> moved;
  std::shared_ptr<ExportResult> exported;
  kj::Own<kj::CrossThreadPromiseFulfiller<void>> fulfiller;
  void done(HistoryMoveResult r) {
    *moved = std::move(r);
    fulfiller->fulfill();
  }
  void done(ExportResult r) {
    *exported = std::move(r);
    fulfiller->fulfill();
  }
};

// What the store thread writes, in the order it was queued.
struct Keeper::Job {
  enum class Kind { journal, scene_start, snapshot, export_file };
  Kind kind = Kind::journal;
  // journal: the records (store tick, end offset in `bytes`); `mark`: the
  // tick its mark says was reached (0: no mark); `ran`: ticks finished.
  std::vector<std::byte> bytes;
  std::vector<std::pair<std::uint64_t, std::size_t>> records;
  std::uint64_t mark = 0, ran = 0;
  // scene_start
  JournalEntry scene;
  std::shared_ptr<const SceneBundle> bundle;
  std::uint32_t next_scene = 0;
  // snapshot (its scene's number; keys of the blobs it carries, confirmed
  // to the replica thread once written)
  std::optional<store::PreparedSnapshot> prepared;
  std::uint32_t scene_number = 0;
  std::uint64_t sequence = 0, state_bytes = 0;
  double prepare_ms = 0;
  const char* why = "";
  // export_file
  std::unique_ptr<Request> request;
};

// An undo or redo between its planning and the sim thread's writing it.
struct Keeper::InFlight {
  std::unique_ptr<Request> request;
  struct Sent {
    std::vector<std::uint32_t> blocks;
    std::vector<std::byte> images;  // the sim thread's copy (it may scribble on it)
    HistoryMoveImages message;
  };
  std::deque<Sent> sent;  // a deque: the sim thread holds pointers into it
  std::size_t queued = 0, applied = 0;
  bool closing = false;   // sent: the mark that closes the open strokes (id 0); the plan follows
  HistoryMoveResult result;
};

// What `history` pages through: the strokes in chunks shared with the
// replica thread, each rebuilt only when one of its strokes changed.
struct Keeper::HistoryView {
  std::vector<std::shared_ptr<const std::vector<StrokeInfo>>> chunks;  // in stroke order
  std::vector<std::uint64_t> starts;  // the index of each chunk's first stroke
  std::uint64_t total = 0, budget = 0, used = 0, dropped = 0;
  std::uint32_t scene = 0;
};

}  // namespace sculpt::daemon
