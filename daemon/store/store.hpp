// sculpt::store — one sculpt's state on disk, recoverable after any crash:
// periodic snapshots (the whole simulation state at a tick, opaque bytes)
// plus a journal of every input since (opaque records with their tick), in
// one SQLite database in WAL mode (docs/store.md).
//
// Contracts
// - Not real-time. Every call may block on the disk (an fsync per commit);
//   the simulation thread never calls it. One thread at a time uses a Store.
// - One Store per directory: open() takes an exclusive flock on the
//   directory itself and on "<dir>/lock" (released by the kernel however the
//   process ends) and refuses a second opener, naming the lock file and the
//   holder's PID (store/dir_lock.hpp).
// - Never destroys a sculpt: a store replaced (adopt) or started anew
//   (set_aside) is kept beside it under a generation name
//   ("previous-<time>-<n>.db", or "unrecovered-..." for one that could not
//   be recovered); the oldest go only when a newer one of their kind is kept.
// - Notices when its files are taken away: before every write it checks that
//   the directory, store.db and store.db-wal are still the files it opened;
//   when one was removed or replaced it writes its whole content (which its
//   open connection still reads) back under the names, and Health says so.
// - Durable: a write that returns ok is committed and fsynced (WAL,
//   synchronous=FULL), so a crash, SIGKILL or power cut afterwards loses
//   nothing of it. A crash during a write loses that write only, never an
//   earlier one, and never leaves a half-written one behind.
// - Ticks: a snapshot at tick T holds the state after every input of a tick
//   <= T. recover() returns the newest snapshot that decodes and passes its
//   checksum, then every journal record of a tick > T, ordered by tick and,
//   within a tick, by append order. Ticks are expected never to go back.
// - Bounded: the database never exceeds Limits::max_bytes (SQLite's
//   max_page_count; a write that would is refused as "disk full"). A
//   snapshot leaves the newest keep_snapshots snapshots and the journal they
//   need, and checkpoints the WAL back to empty.
// - Faults never stop the caller. Writes do not throw for disk faults (full,
//   read-only, I/O errors): they return a failed Status naming the database
//   and SQLite's error, and the store is degraded. While degraded, writes
//   within retry_interval of the last failure return at once (deferred,
//   without touching the disk); the next one after it retries. Journal
//   records not yet written are kept in memory, up to max_pending_bytes, and
//   written first by the next write that succeeds; records beyond that are
//   dropped and their tick range is recorded, so recover() reports the gap.
// - recover() never throws for a damaged store: it returns what is good and
//   says what was lost and why.
// - Untrusted on reading: a store may be a file from anywhere (`--open`).
//   Every value read is checked against Limits' caps before it is used or
//   allocated for (a declared size before decoding, a value's length before
//   SQLite loads it, the journal's records and bytes, the snapshots tried),
//   and what exceeds one is refused by name, as damage.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "store/codec.hpp"
#include "store/dir_lock.hpp"
#include "store/sqlite.hpp"

namespace sculpt::store {

// open() failed: the message names the path and what is wrong.
class StoreError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
// open() failed because another process holds the store.
class StoreInUse : public StoreError {
 public:
  using StoreError::StoreError;
};

struct Limits {
  std::uint64_t max_bytes = std::uint64_t{1} << 30;  // the database file, at most
  unsigned keep_snapshots = 3;                       // at least 1
  std::chrono::milliseconds retry_interval{5000};    // while degraded
  std::uint64_t max_pending_bytes = std::uint64_t{64} << 20;  // unwritten journal held in memory
  Codec codec = Codec::shuffle4_zstd;
  int zstd_level = 1;
  // Reading (docs/store.md, "Caps"): the most a store file can make
  // recovery allocate or do. Writes never make more.
  std::uint64_t max_decoded_bytes = kMaxDecodedBytes;         // one state or blob, decoded
  std::uint64_t max_meta_bytes = std::uint64_t{4} << 20;      // one snapshot's meta text
  std::uint64_t max_blob_refs = 16384;                        // blobs one snapshot refers to
  std::uint64_t max_key_bytes = 1024;                         // one blob key
  std::uint64_t max_record_bytes = std::uint64_t{64} << 10;   // one journal record
  std::uint64_t max_journal_records = std::uint64_t{1} << 20; // read after a snapshot
  std::uint64_t max_journal_bytes = std::uint64_t{64} << 20;  // ...and their bytes
  unsigned max_snapshots_tried = 8;                           // newest first
  unsigned max_gaps_reported = 16;
};

struct RecordView {
  std::uint64_t tick = 0;
  std::span<const std::byte> bytes;
};

struct Record {
  std::uint64_t tick = 0;
  std::vector<std::byte> bytes;
  bool operator==(const Record&) const = default;
};

// A value a snapshot refers to by key, written once and shared by every
// snapshot that refers to it (a scene's files, a stroke's images): kept
// while any kept snapshot does. Encoded like a snapshot.
struct BlobWrite {
  std::string key;
  std::span<const std::byte> bytes;
};

// A snapshot encoded and ready to write (Store::prepare_snapshot): the slow
// part, compression, done without the store.
struct PreparedSnapshot {
  struct Blob {
    std::string key;
    std::uint64_t raw_size = 0;
    std::vector<std::byte> data;
  };
  std::uint64_t tick = 0, raw_size = 0;
  std::vector<std::byte> data;
  std::string meta;
  std::vector<Blob> blobs;
  std::vector<std::string> refs;
};

struct Snapshot {
  std::uint64_t tick = 0;
  std::vector<std::byte> state;
  std::string meta;
  std::map<std::string, std::vector<std::byte>> blobs;  // what it refers to (those that decode)
};

// A snapshot as recover() finds it before anything is decoded: what a Judge
// looks at to decide whether to use it, and what to read of it.
struct StoredSnapshot {
  std::int64_t id = 0;
  std::uint64_t tick = 0;
  std::uint64_t raw_size = 0;                  // its state, decoded
  std::string meta;
  std::map<std::string, std::uint64_t> blobs;  // every blob it refers to that is stored → its decoded size
  std::vector<std::string> missing;            // ...and those that are not
};
// "" : use this snapshot; else why not (recover() goes on to the one before).
// It reads what it needs with Store::read_state and read_blob.
using Judge = std::function<std::string(const StoredSnapshot&)>;

struct Status {
  bool ok = true;
  bool deferred = false;  // not tried: degraded, the retry is not due yet
  std::string error;      // empty when ok
  explicit operator bool() const { return ok; }
};

struct Recovery {
  std::optional<Snapshot> snapshot;  // none: the store is new, or no snapshot decodes
  std::vector<Record> journal;       // after the snapshot's tick (all, when there was never one)
  std::vector<std::string> lost;     // what could not be recovered and why; empty: exact
  bool exact() const { return lost.empty(); }
};

struct Health {
  bool degraded = false;
  std::string last_error;            // of the failure that degraded it
  std::uint64_t failures = 0;        // write attempts that failed, ever
  std::size_t pending_records = 0;   // journal records waiting in memory
  std::uint64_t dropped_records = 0; // not written and not kept, ever
  std::uint64_t relocations = 0;     // times its files were found removed or replaced
  std::string relocation;            // the last: what was found, and what was done
  bool unnamed = false;              // its files have no name now (not rewritten yet): a crash loses them
};

// What a store that is put aside is kept as.
enum class Kept {
  previous,     // a sculpt that was recovered or ran: "previous-<time>-<n>.db"
  unrecovered,  // one that could not be recovered: "unrecovered-<time>-<n>.db"
};

struct Usage {
  std::int64_t snapshots = 0;
  std::int64_t journal_records = 0;
  std::uint64_t database_bytes = 0;  // the file's size
  std::uint64_t wal_bytes = 0;       // the -wal file's size
};

class Store {
 public:
  // Creates `dir` (0750) and the database if missing, locks, checks the
  // schema. Throws StoreError: the directory cannot be made, the store is
  // locked, the file is not a store or has a newer schema, SQLite cannot
  // open it.
  static Store open(const std::filesystem::path& dir, const Limits& limits = {});
  Store(Store&&) noexcept;
  Store& operator=(Store&&) = delete;
  ~Store();

  // A copy of `file` (a .sculpt written by export_copy) in this store's
  // directory ("opening.db"), opened as a store of its own: recover() it,
  // then adopt() it; dropped, it deletes its copy. Nothing of this store is
  // touched. Throws StoreError naming the file: unreadable, not a store, a
  // newer schema, damaged (quick_check).
  Store open_candidate(const std::filesystem::path& file);
  // Makes `candidate` this directory's store. The store it replaces, unless
  // empty, is kept as a generation of `kept` (its path returned; empty when
  // nothing was kept). Throws StoreError; then this store is as it was.
  std::filesystem::path adopt(Store&& candidate, Kept kept = Kept::previous);
  // Keeps this store's database as a generation of `kind` and starts an
  // empty one in its place (a sculpt started anew): the path it is kept
  // under, empty when the store was empty (nothing kept). Throws StoreError;
  // then nothing was changed.
  std::filesystem::path set_aside(Kept kind);
  // The generations of `kind` kept in `dir`, oldest first.
  static std::vector<std::filesystem::path> generations(const std::filesystem::path& dir, Kept kind);
  static constexpr std::size_t kKeptGenerations = 3;  // of each kind

  // `blobs`: new ones (a key already stored is kept as it is); `refs`: the
  // keys of every blob this snapshot needs, new or already stored.
  Status write_snapshot(std::uint64_t tick, std::span<const std::byte> state, std::string_view meta = {},
                        std::span<const BlobWrite> blobs = {}, std::span<const std::string> refs = {});
  // The same in two steps: prepare_snapshot encodes (no disk; it reads only
  // the limits, so another thread may call it while one uses the store),
  // write_snapshot(prepared) writes. Throws StoreError for a state or blob
  // larger than Limits::max_decoded_bytes (recover() would not read it).
  PreparedSnapshot prepare_snapshot(std::uint64_t tick, std::span<const std::byte> state, std::string_view meta,
                                    std::span<const BlobWrite> blobs, std::span<const std::string> refs) const;
  Status write_snapshot(const PreparedSnapshot& prepared);
  Status append(std::span<const RecordView> records);  // one transaction
  // Whether the store's files are where they were, putting them back (as a
  // write would) when not: for a store that has nothing to write for a
  // while. Not ok (and deferred) only when they could not be put back.
  Status check_files();
  // Journal records the caller dropped before they reached the store (its
  // own memory bound): recorded as a gap with the next write, as the
  // store's own dropped records are.
  void record_dropped(std::uint64_t first_tick, std::uint64_t last_tick, std::uint64_t records);
  // The newest snapshot whose state and blobs all decode, and the journal after it.
  Recovery recover();
  // The newest snapshot `judge` takes (at most Limits::max_snapshots_tried
  // are offered, newest first) and the journal after it; Recovery::snapshot
  // then holds its tick and meta only (the judge read what it needed).
  // What the judge throws goes to the caller.
  Recovery recover(const Judge& judge);
  // A snapshot's state or a blob, decoded; nullopt (with `why`) when it is
  // missing, damaged, or larger than `max_bytes` (checked before decoding).
  std::optional<std::vector<std::byte>> read_state(const StoredSnapshot& s, std::uint64_t max_bytes, std::string& why);
  std::optional<std::vector<std::byte>> read_blob(const std::string& key, std::uint64_t max_bytes, std::string& why);
  const Limits& limits() const { return limits_; }
  // Deletes every snapshot, journal record and blob: a sculpt starts anew
  // (its ticks start again from 0). Throws StoreError.
  void clear();

  // A consistent copy of the whole store as one database file (`VACUUM
  // INTO`): what `sculptctl export` hands out, with the journal records held
  // in memory (a disk that refuses writes) added to it. Not fsynced (the
  // caller syncs a copy it keeps). Throws StoreError.
  void export_copy(const std::filesystem::path& file);

  Health health() const;
  Usage usage();
  const std::filesystem::path& database() const { return file_; }
  const std::filesystem::path& dir() const { return dir_; }

  // Tests only: runs SQL on the store's own connection, to simulate faults
  // (PRAGMA max_page_count, PRAGMA query_only). Throws sqlite::Error.
  void execute_for_testing(std::string_view sql) { db_.exec(sql, "test hook"); }

 private:
  Store(std::unique_ptr<DirLock> lock, std::filesystem::path file, sqlite::Connection db, const Limits& limits);
  void remember_files();
  std::string files_taken() const;
  void keep_files_named(std::chrono::steady_clock::time_point now);
  void relocate(const std::string& what);
  void discard_candidate();
  bool holds_nothing();
  template <class Write>
  Status attempt(std::string_view doing, Write&& write,
                 std::chrono::steady_clock::time_point now = std::chrono::steady_clock::now());
  void keep_pending(std::span<const RecordView> records);
  void write_journal(std::span<const RecordView> records);
  void written();
  void insert_snapshot(const PreparedSnapshot& s);
  void wal_checkpoint();
  std::optional<StoredSnapshot> describe(std::int64_t id, std::uint64_t tick, std::string& why);
  void load_journal(std::int64_t after, Recovery& out);
  void report_gaps(std::int64_t after, Recovery& out);

  struct Gap {
    std::uint64_t first_tick = 0, last_tick = 0, records = 0;
  };

  std::unique_ptr<DirLock> lock_;  // none: a candidate (inside a locked directory)
  std::filesystem::path dir_, file_;
  sqlite::Connection db_;
  FileId db_id_, wal_id_;  // what store.db and store.db-wal were when opened
  std::chrono::steady_clock::time_point relocate_at_{};  // while unnamed: the next try
  Limits limits_;
  std::deque<Record> pending_;
  std::uint64_t pending_bytes_ = 0;
  std::optional<Gap> gap_;  // dropped records not yet recorded on disk
  Health health_;
  std::chrono::steady_clock::time_point retry_at_{};
};

}  // namespace sculpt::store
