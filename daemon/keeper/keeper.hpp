// The keeper keeps the sculpt safe: its journal and snapshots in the store,
// its history and its recovery, on three threads of its own beside the sim
// loop. The sim thread tells it what it did (keeper/journal.hpp); the keeper's journal thread
//   - takes that from the tap every 10 ms and seals it into a batch, with a
//     mark of the last tick finished, every commit_every (50 ms), for the
//     store thread, and an export after what it sealed; it never waits on
//     the disk;
// its store thread, the only one that touches the store after start(),
//   - writes the batches (one transaction, fsynced), the scene starts, the
//     snapshots the replica thread prepared, and the exports, in order; a
//     stalled disk holds up this thread only (what waits meanwhile is
//     bounded by store::Limits::max_pending_bytes);
// and its replica thread, at SCHED_IDLE (it takes a CPU only when nothing
// else wants it: the replica costs what the sim thread's world costs)
//   - replays it on the replica (keeper/replica.hpp), whose strokes become the
//     strokes of the History (keeper/history.hpp);
//   - prepares snapshots of the replica (never of the real-time world) every
//     snapshot_every, or once it has stepped replay_work_per_snapshot, and
//     at the end;
//   - prepares undo and redo: the images go to the sim thread, which
//     writes them between ticks, and come back in the journal. Neither
//     waits on the disk.
// At start, recover() rebuilds the sculpt from the store: the last snapshot
// and the journal after it, replayed to the last tick committed; open_file()
// does the same from a .sculpt file in a scratch store first, and only a
// file that recovers replaces the store (which is kept, store::Kept).
//
// Faults: a store that fails (disk full, read-only, I/O errors, its files
// removed) never stops the sculpt: the keeper logs it once, keeps what it
// could not write in memory (store::Limits::max_pending_bytes) and retries;
// a small marker outside the store (keeper/save_marker.hpp) tells the next
// start what a crash meanwhile lost.
//
// Each thread's code has its own file: journal_thread.cpp, store_thread.cpp
// (with snapshots.cpp), replica_thread.cpp; recovery.cpp is recover() and
// open_file(); keeper.cpp the start, the stop and the io thread's API.
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
#include <unordered_set>
#include <string>
#include <thread>
#include <vector>

#include <kj/async.h>
#include <nlohmann/json_fwd.hpp>

#include "keeper/history.hpp"
#include "keeper/journal.hpp"
#include "keeper/replica.hpp"
#include "keeper/save_marker.hpp"
#include "keeper/scene_bundle.hpp"
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
  // What the log's summary says of the loss: "nothing saved was lost" only
  // when the state is the last committed tick of an intact journal and no
  // witness of the run that ended says more was lost.
  std::string loss;
  // The replay stopped before the journal's end (a record it could not use):
  // what follows is not this state's, and must not be replayed onto it later.
  bool replay_stopped = false;
  double seconds = 0;
};

struct HistoryMoveResult {
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
  double snapshot_ms = 0;                  // the last one's: state and encoding (replica thread), commit and checkpoint (store thread)
  std::uint64_t replica_behind = 0;   // ticks the replica was behind at the last look
};

// One page of the history: at most `limit` strokes.
struct HistoryInfo {
  std::vector<StrokeInfo> strokes;  // oldest first
  std::uint64_t budget = 0, used = 0, dropped = 0;
  std::uint32_t scene = 0;   // the running scene's number
  std::uint64_t total = 0;   // strokes held
  std::uint64_t older = 0;   // held strokes before this page
  std::uint64_t newer = 0;   // held strokes after it
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
  // true makes it throw RecoveryStopped (nothing was changed). A replay
  // that stopped short keeps the store as it was (a generation) and starts
  // a new one from the state recovered.
  std::optional<Recovered> recover(const std::function<bool()>& stop_requested = {});
  // Before start(), instead of recover(): the sculpt in `file` (a .sculpt),
  // recovered from a copy of it in a scratch store, with the same checks;
  // only then does it become the store, the one it replaces kept as a
  // generation (the log says where). Throws std::runtime_error naming the
  // file when it is not a sculpt or nothing can be recovered from it: then
  // nothing was changed.
  Recovered open_file(const std::filesystem::path& file, const std::function<bool()>& stop_requested = {});
  // Before start(), instead of recover() or when it found nothing: a new
  // store (the new sculpt's ticks start at 0); what the old one held is kept
  // as a generation beside it (store::Kept::unrecovered when recover() could
  // not use it). Throws store::StoreError; then nothing was changed.
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
  kj::Promise<HistoryMoveResult> undo(std::uint32_t count);
  kj::Promise<HistoryMoveResult> redo(std::uint32_t count);
  kj::Promise<ExportResult> export_sculpt();
  // The strokes numbered `from` and up, at most `limit` (1..kMaxHistoryPage;
  // 0: kMaxHistoryPage); from 0: the newest `limit`. Cheap: never waits on
  // the keeper's threads nor copies the whole history.
  HistoryInfo history(std::uint32_t from = 0, std::uint32_t limit = 0) const;
  static constexpr std::uint32_t kMaxHistoryPage = 16384;
  store::Health health() const;
  KeeperStats stats() const;

 private:
  struct Request;
  struct InFlight;
  struct Job;
  struct HistoryView;
  // The journal thread: what the sim thread did, sealed into batches.
  void run_journal();
  void collect();
  void seal();
  void queue_job(std::unique_ptr<Job> job);
  // The store thread: every write, in order.
  void run_store();
  void write_batches(std::vector<std::unique_ptr<Job>>& batches);
  void write_scene_start(Job& job);
  void write_snapshot(Job& job);
  void write_export(Job& job);
  void store_written(const store::Status& st, const char* what);
  double seconds_of(std::uint64_t ticks) const;
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
  void send_history_moves();
  void history_move_applied(const JournalEntry& e);
  void finish_requests();
  void publish_history();
  kj::Promise<HistoryMoveResult> move_history(bool undo, std::uint32_t count);
  template <class Result>
  kj::Promise<Result> ask(std::unique_ptr<Request> r, std::shared_ptr<Result> out);
  std::optional<Recovered> recover_store(store::Store& store, const std::function<bool()>& stop_requested,
                                         std::vector<std::string>& why, bool own);
  void use_snapshot(store::Store& store, const store::StoredSnapshot& snap, Recovered& out);
  std::deque<Stroke> read_strokes(store::Store& store, const store::StoredSnapshot& snap, const nlohmann::json& keys,
                                  std::uint32_t next_stroke, std::uint64_t& dropped);
  std::string replay(const std::vector<store::Record>& journal, const std::function<bool()>& stop_requested,
                     Recovered& out);
  bool advance_replica(std::uint64_t tick, std::chrono::steady_clock::time_point deadline,
                       const std::function<bool()>& stop_requested);
  void explain_loss(const std::vector<store::Record>& journal, const std::string& stopped, bool own, Recovered& out);
  void restart_store_from(const Recovered& rec);
  void reset_history();

  KeeperSettings settings_;
  JournalTap& tap_;
  store::Store store_;  // the store thread's alone once start() ran
  std::optional<SaveState> previous_run_;  // what the daemon before this one left unsaved
  bool unrecovered_ = false;  // recover() found a sculpt it could not use

  // Journal thread.
  std::vector<std::byte> batch_bytes_;                        // encoded, not yet sealed
  std::vector<std::pair<std::uint64_t, std::size_t>> batch_;  // store tick, end offset in batch_bytes_
  std::uint64_t collected_ = 0;  // ticks before it are finished and their entries taken
  std::uint64_t marked_ = 0;     // the last mark sealed
  std::chrono::steady_clock::time_point next_commit_{};

  // Store thread.
  SaveMarker marker_;
  SaveState saved_;                      // what the marker says
  std::uint64_t unconfirmed_mark_ = 0;   // the newest mark handed to the store
  std::uint32_t scene_started_ = 0;      // the newest scene whose start is written: older scenes' snapshots are obsolete
  std::chrono::steady_clock::time_point last_commit_{};
  std::uint64_t relocations_seen_ = 0;

  // Replica thread (and recover(), before it runs).
  History history_;
  std::unique_ptr<Replica> replica_;
  std::deque<JournalEntry> inbox_;  // taken from the journal thread, not yet replayed
  std::uint64_t finished_ = 0;      // ticks before it are finished and their entries in the inbox
  std::chrono::steady_clock::time_point next_snapshot_{};
  std::chrono::steady_clock::duration replayed_since_snapshot_{};  // the replica's stepping time
  std::map<std::uint32_t, std::string> stroke_keys_;  // stroke number → its blob's key
  std::set<std::uint32_t> unsaved_;                   // strokes changed since the last snapshot
  std::string bundle_key_;
  std::map<std::string, std::string> refused_bundles_;  // recover(): a bundle's key → why it was refused
  std::unordered_set<std::string> confirmed_keys_;  // blobs the newest snapshot written holds
  std::uint64_t snapshot_sequence_ = 0;
  std::unique_ptr<InFlight> in_flight_;
  bool background_ = false;  // SCHED_IDLE now
  std::map<std::uint32_t, std::shared_ptr<const std::vector<StrokeInfo>>> history_chunks_;  // by number >> kChunkBits

  // Shared, under mutex_.
  mutable std::mutex mutex_;
  std::condition_variable wake_, store_wake_;
  bool stop_ = false, journal_done_ = false, replica_done_ = false;
  std::uint64_t collect_asked_ = 0, collect_done_ = 0;  // the replica thread asks for a collect now
  std::deque<JournalEntry> to_replica_;  // the journal thread's entries for the replica thread
  std::uint64_t finished_shared_ = 0;
  std::deque<std::unique_ptr<Request>> requests_;  // undo and redo, for the replica thread
  std::deque<std::unique_ptr<Request>> exports_;   // for the journal thread
  std::deque<std::unique_ptr<Job>> jobs_;  // for the store thread, in order
  std::uint64_t queued_journal_bytes_ = 0;
  struct Dropped {
    std::uint64_t first = 0, last = 0, records = 0;
  };
  Dropped dropped_;  // journal records dropped from the queue, for the store's gap
  // Snapshots written (sequence, the keys of the blobs they refer to), for the replica thread.
  std::vector<std::pair<std::uint64_t, std::vector<std::string>>> written_snapshots_;
  bool snapshot_soon_ = false;  // the store thread asks for one (its files were written back)
  double rate_hz_ = 1000;       // of the running scene
  struct Incoming {
    std::shared_ptr<const SceneBundle> bundle;
    std::shared_ptr<const scene::Scene> scene;
    std::uint64_t first_tick = 0;
  };
  std::map<std::uint32_t, Incoming> incoming_;
  std::uint32_t next_scene_ = 1;
  std::shared_ptr<const HistoryView> shown_;
  store::Health health_;
  std::string last_store_error_;  // logged once until it changes
  KeeperStats stats_;
  std::thread journal_thread_, store_thread_, replica_thread_;
};

}  // namespace sculpt::daemon
