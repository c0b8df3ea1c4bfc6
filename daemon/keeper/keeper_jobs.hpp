// The keeper's requests and the store thread's jobs (keeper/keeper.hpp):
// shared by keeper.cpp and keeper_store.cpp only.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <kj/async.h>

#include "keeper/keeper.hpp"

namespace sculpt::daemon {

struct Keeper::Request {
  enum class Kind { undo, redo, export_file };
  Kind kind = Kind::undo;
  std::uint32_t count = 0;
  // The result waits beside a void promise (as in host/worker.hpp): gcc 12
  // warns (-Wmaybe-uninitialized, a false positive) about any value inside
  // kj's cross-thread promise.
  std::shared_ptr<EditResult> edited;
  std::shared_ptr<ExportResult> exported;
  kj::Own<kj::CrossThreadPromiseFulfiller<void>> fulfiller;
  void done(EditResult r) {
    *edited = std::move(r);
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

}  // namespace sculpt::daemon
