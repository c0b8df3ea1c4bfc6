// The keeper: the sculpt's autosave, its history and its recovery, on two
// threads of its own beside the real-time loop. The sim thread tells it what
// it did (main/journal.hpp); the keeper's journal thread
//   - commits that to the store's journal (store/store.hpp) every
//     commit_every (50 ms), with a mark of the last tick finished;
// and its replica thread, at SCHED_IDLE (it takes a CPU only when nothing
// else wants it: the replica costs what the sim thread's world costs)
//   - replays it on the replica (main/replica.hpp), whose edits become the
//     strokes of the History (main/history.hpp);
//   - snapshots the replica (never the real-time world) every
//     snapshot_every, at each scene swap, before an export and at the end;
//   - prepares undo and redo: the images go to the sim thread, which
//     writes them between ticks, and come back in the journal.
// At start, recover() rebuilds the sculpt from the store: the last snapshot
// and the journal after it, replayed to the last tick committed.
//
// Faults: a store that fails (disk full, read-only, I/O errors) never stops
// the sculpt: the keeper logs it once, keeps what it could not write in
// memory (store::Limits::max_pending_bytes) and retries.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <kj/async.h>
#include <nlohmann/json_fwd.hpp>

#include "main/history.hpp"
#include "main/journal.hpp"
#include "main/replica.hpp"
#include "main/scene_bundle.hpp"
#include "store/store.hpp"

namespace sculpt::daemon {

struct KeeperSettings {
  std::filesystem::path dir;                       // the store's directory
  store::Limits limits;
  std::chrono::milliseconds commit_every{50};      // the journal: at most this much input is lost
  std::chrono::milliseconds snapshot_every{30000};
  // Also a snapshot once the replica has spent this long stepping since the
  // last: recovery replays that much work at most (a big mesh sculpted hard
  // steps slowly), whatever snapshot_every says.
  std::chrono::milliseconds replay_work_per_snapshot{5000};
  std::uint64_t history_budget = std::uint64_t{256} << 20;
  std::size_t max_strokes = kMaxStrokes;
  // Recovery replays at most this much after the snapshot (a store is
  // untrusted input: no file can make it step forever): a journal record
  // further on in sculpt time (ticks at the scene's rate) stops the replay
  // there, and so does the wall clock. The span is the longest
  // snapshot_interval_s the config allows.
  std::chrono::seconds replay_span_limit{86400};
  std::chrono::milliseconds replay_time_limit{60000};
};

// recover() stopped because its caller asked (SIGTERM during the replay);
// nothing was changed.
class RecoveryStopped : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// What recovery hands the daemon to start from.
struct Recovered {
  std::shared_ptr<const SceneBundle> bundle;
  scene::Scene scene;
  std::vector<std::byte> state;   // Replica::state()
  std::uint64_t first_tick = 0;   // the world's origin (SimThreadOptions::first_tick)
  std::uint64_t next_tick = 0;    // the tick the sim thread runs next
  bool paused = false;
  std::uint64_t hash = 0;         // the meshes' hash (World::hash)
  std::size_t replayed = 0;       // journal entries replayed after the snapshot
  std::uint64_t snapshot_tick = 0;
  std::size_t strokes = 0;
  std::int64_t committed_ns = 0;  // when the last journal commit was made (CLOCK_REALTIME; 0: none)
  std::vector<std::string> lost;  // empty: exact
  double seconds = 0;
};

struct EditResult {
  std::string error;
  std::uint32_t done = 0;
  std::uint64_t tick = 0;
};

struct ExportResult {
  std::string error;
  int fd = -1;
  std::uint64_t bytes = 0;
};

struct StrokeInfo {
  std::uint32_t number = 0, body = 0, scene = 0;
  std::string mesh_name;
  std::uint64_t tools = 0;  // bit t: tool slot t
  std::uint64_t first_tick = 0, end_tick = 0, vertices = 0, bytes = 0;
  bool undone = false;
};

// What the keeper has done, for the log at exit and the benchmarks.
struct KeeperStats {
  std::uint64_t entries = 0;          // journal entries taken from the sim thread
  std::uint64_t journal_bytes = 0;    // their encoded bytes (marks included)
  std::uint64_t commits = 0;          // journal transactions tried
  double longest_commit_gap_ms = 0;   // between two journal commits
  std::uint64_t snapshots = 0;
  std::uint64_t snapshot_state_bytes = 0;  // the last one's, before encoding
  std::uint64_t snapshot_stored_bytes = 0; // ...and encoded (its new blobs too)
  double snapshot_ms = 0;                  // the last one's: state, encoding, commit, checkpoint
  std::uint64_t replica_behind = 0;   // ticks the replica was behind at the last look
};

struct HistoryInfo {
  std::vector<StrokeInfo> strokes;
  std::uint64_t budget = 0, used = 0, dropped = 0;
  std::uint32_t scene = 0;  // the running scene's number
};

class Keeper {
 public:
  // Opens the store in settings.dir. Throws store::StoreError naming the
  // directory and what is wrong (in use by another daemon, not a store).
  Keeper(KeeperSettings settings, JournalTap& tap);
  ~Keeper();
  Keeper(const Keeper&) = delete;
  Keeper& operator=(const Keeper&) = delete;

  // Before start(): the sculpt in the store, replayed to its last committed
  // tick; nullopt when the store holds none (new, or --fresh). Never
  // throws for damage: what could not be recovered is in Recovered::lost.
  // Everything read is checked before it is used (docs/store.md, "What
  // recovery checks"); a snapshot that does not fit is refused by name and
  // the one before it tried. `stop_requested`, asked between replay steps:
  // true makes it throw RecoveryStopped.
  std::optional<Recovered> recover(const std::function<bool()>& stop_requested = {});
  // Before start(), instead of recover() or when it found nothing: empties
  // the store (the new sculpt's ticks start at 0), keeping what it held as
  // "previous.db" beside it. Throws store::StoreError.
  void start_anew();

  // io thread, while no sim thread runs: the scene the next sim thread
  // runs, from `first_tick`. `recovered`: it continues recover()'s replica.
  void scene_started(std::shared_ptr<const SceneBundle> bundle, std::shared_ptr<const scene::Scene> scene,
                     std::uint64_t first_tick, bool recovered = false);

  void start();
  // Takes what the sim thread left, commits it, writes a last snapshot.
  // Call after the sim thread stopped.
  void stop();

  // io thread.
  kj::Promise<EditResult> undo(std::uint32_t count);
  kj::Promise<EditResult> redo(std::uint32_t count);
  kj::Promise<ExportResult> export_sculpt();
  HistoryInfo history() const;
  store::Health health() const;
  KeeperStats stats() const;

 private:
  struct Request;
  struct InFlight;
  // The journal thread: what the sim thread did, to disk.
  void run_journal();
  void collect();
  void commit();
  void write_scene_start(const JournalEntry& scene);
  // The replica thread (SCHED_IDLE): the replica, the history, snapshots, requests.
  void run_replica();
  void set_background(bool background);
  bool take_entries(std::unique_ptr<Request>& request);
  bool replay_some(std::chrono::steady_clock::time_point until);
  void replay_all();
  void catch_up();
  void switch_scene(std::uint32_t number);
  void snapshot(const char* why);
  void serve(std::unique_ptr<Request> r);
  bool plan(InFlight& f);
  void send_edits();
  void edit_applied(const JournalEntry& e);
  void finish_requests();
  void publish_history();
  ExportResult export_now();
  kj::Promise<EditResult> edit(bool undo, std::uint32_t count);
  template <class Result>
  kj::Promise<Result> ask(std::unique_ptr<Request> r, std::shared_ptr<Result> out);
  void use_snapshot(const store::StoredSnapshot& snap, Recovered& out);
  std::deque<Stroke> read_strokes(const store::StoredSnapshot& snap, const nlohmann::json& keys,
                                  std::uint32_t next_stroke, std::uint64_t& dropped);
  std::string replay(const std::vector<store::Record>& journal, const std::function<bool()>& stop_requested,
                     Recovered& out);
  bool advance_replica(std::uint64_t tick, std::chrono::steady_clock::time_point deadline,
                       const std::function<bool()>& stop_requested);

  KeeperSettings settings_;
  JournalTap& tap_;
  std::mutex store_mutex_;  // the store: the journal thread's commits, the replica thread's snapshots
  store::Store store_;

  // Journal thread.
  std::vector<std::byte> batch_bytes_;                        // encoded, not yet committed
  std::vector<std::pair<std::uint64_t, std::size_t>> batch_;  // store tick, end offset in batch_bytes_
  std::uint64_t collected_ = 0;  // ticks before it are finished and their entries taken
  std::uint64_t marked_ = 0;     // the last mark committed
  std::chrono::steady_clock::time_point next_commit_{}, last_commit_{};

  // Replica thread (and recover(), before it runs).
  History history_;
  std::unique_ptr<Replica> replica_;
  std::deque<JournalEntry> inbox_;  // taken from the journal thread, not yet replayed
  std::uint64_t finished_ = 0;      // ticks before it are finished and their entries in the inbox
  std::chrono::steady_clock::time_point next_snapshot_{};
  std::chrono::steady_clock::duration replayed_since_snapshot_{};  // the replica's stepping time
  std::map<std::uint32_t, std::string> stroke_keys_;  // stroke number → its stored blob's key
  std::set<std::uint32_t> unsaved_;                   // strokes changed since the last snapshot
  std::string bundle_key_;
  bool bundle_stored_ = false;
  std::map<std::string, std::string> refused_bundles_;  // recover(): a bundle's key → why it was refused
  std::unique_ptr<InFlight> in_flight_;
  bool background_ = false;  // SCHED_IDLE now

  // Shared, under mutex_.
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false, journal_done_ = false;
  std::uint64_t collect_asked_ = 0, collect_done_ = 0;  // the replica thread asks for a collect now
  std::deque<JournalEntry> to_replica_;  // the journal thread's entries for the replica thread
  std::uint64_t finished_shared_ = 0;
  std::deque<std::unique_ptr<Request>> requests_;
  struct Incoming {
    std::shared_ptr<const SceneBundle> bundle;
    std::shared_ptr<const scene::Scene> scene;
    std::uint64_t first_tick = 0;
  };
  std::map<std::uint32_t, Incoming> incoming_;
  std::uint32_t next_scene_ = 1;
  HistoryInfo shown_;
  store::Health health_;
  std::string last_store_error_;  // logged once until it changes
  KeeperStats stats_;
  std::thread journal_thread_, replica_thread_;
};

}  // namespace sculpt::daemon
