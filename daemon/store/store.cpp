#include "store/store.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <utility>

#include "files/regular_file.hpp"

namespace sculpt::store {
namespace {

constexpr std::int64_t kApplicationId = 0x53434C50;  // "SCLP": this file is a sculptd store
constexpr std::int64_t kSchemaVersion = 1;

constexpr std::string_view kSchema = R"sql(
CREATE TABLE snapshot (
  id       INTEGER PRIMARY KEY,  -- write order: the newest has the largest id
  tick     INTEGER NOT NULL,
  codec    INTEGER NOT NULL,     -- store::Codec
  raw_size INTEGER NOT NULL,     -- bytes before encoding
  meta     TEXT NOT NULL,
  data     BLOB NOT NULL
);
CREATE TABLE journal (
  seq  INTEGER PRIMARY KEY,      -- append order
  tick INTEGER NOT NULL,
  data BLOB NOT NULL
);
CREATE INDEX journal_by_tick ON journal (tick, seq);
CREATE TABLE gap (               -- journal records dropped while the disk failed
  first_tick INTEGER NOT NULL,
  last_tick  INTEGER NOT NULL,
  records    INTEGER NOT NULL
);
CREATE TABLE blob (              -- immutable by key; kept while a snapshot refers to it
  key      TEXT PRIMARY KEY,
  codec    INTEGER NOT NULL,
  raw_size INTEGER NOT NULL,
  data     BLOB NOT NULL
);
CREATE TABLE snapshot_blob (
  snapshot INTEGER NOT NULL,
  key      TEXT NOT NULL
);
CREATE INDEX snapshot_blob_by_snapshot ON snapshot_blob (snapshot);
)sql";

// Creates the schema in a new file, or checks that an existing one is ours
// and not newer than this build.
void check_or_create_schema(sqlite::Connection& db) {
  sqlite::Transaction tx(db);
  const std::int64_t app = db.query_int("PRAGMA application_id", "read the application id");
  const std::int64_t version = db.query_int("PRAGMA user_version", "read the schema version");
  const std::int64_t tables = db.query_int("SELECT count(*) FROM sqlite_schema", "list the tables");
  if (app == 0 && version == 0 && tables == 0) {
    db.exec(kSchema, "create the schema");
    db.exec(fmt::format("PRAGMA application_id = {}; PRAGMA user_version = {}", kApplicationId, kSchemaVersion),
            "set the schema version");
    tx.commit();
    return;
  }
  if (app != kApplicationId)
    throw StoreError(fmt::format("{}: is an SQLite database but not a sculptd store (application id {:#x})",
                                 db.file().string(), app));
  if (version != kSchemaVersion)
    throw StoreError(fmt::format("{}: store schema version {}, this sculptd reads only version {}{}",
                                 db.file().string(), version, kSchemaVersion,
                                 version > kSchemaVersion ? " (written by a newer sculptd)" : ""));
}

void configure(sqlite::Connection& db, const Limits& limits) {
  // WAL: a commit appends to the -wal file, so a torn write can only hit the
  // uncommitted tail, which recovery discards by its frame checksums.
  {
    sqlite::Statement st(db, "PRAGMA journal_mode = WAL");
    const std::string mode = st.step("switch to WAL") ? st.column_text(0) : std::string();
    if (mode != "wal")
      throw StoreError(fmt::format("{}: cannot switch to WAL mode (journal mode stays \"{}\")", db.file().string(), mode));
  }
  // FULL, not NORMAL: in WAL mode NORMAL skips the fsync at each commit, so
  // a power cut could lose every commit since the last checkpoint; FULL
  // loses at most the commit in progress, for one fsync per commit (<= 10/s).
  db.exec("PRAGMA synchronous = FULL", "set synchronous=FULL");
  const std::int64_t page = db.query_int("PRAGMA page_size", "read the page size");
  const std::uint64_t max_bytes = std::min<std::uint64_t>(limits.max_bytes, INT64_MAX);  // "unlimited" stays so
  const std::int64_t max_pages = std::max<std::int64_t>(16, static_cast<std::int64_t>(max_bytes) / page);
  db.query_int(fmt::format("PRAGMA max_page_count = {}", max_pages), "set the size limit");
  // Between snapshots the journal's commits may grow the WAL past the
  // automatic checkpoint; this truncates it back after each one.
  db.query_int("PRAGMA journal_size_limit = 8388608", "limit the WAL");
}

}  // namespace

Store::Store(DirLock lock, sqlite::Connection db, const Limits& limits)
    : lock_(std::move(lock)), db_(std::move(db)), limits_(limits) {
  limits_.keep_snapshots = std::max(1u, limits_.keep_snapshots);
}

Store Store::open(const std::filesystem::path& dir, const Limits& limits) {
  try {
    files::create_directories(dir, 0750);
  } catch (const files::FileError& e) {
    throw StoreError(e.what());
  }
  DirLock lock(dir);
  try {
    sqlite::Connection db(dir / "store.db", true);
    check_or_create_schema(db);  // first: a file that is not a store is left as it was
    configure(db, limits);
    return Store(std::move(lock), std::move(db), limits);
  } catch (const sqlite::Error& e) {
    throw StoreError(e.what());
  }
}

void Store::import_file(const std::filesystem::path& dir, const std::filesystem::path& file) {
  namespace fs = std::filesystem;
  try {
    files::create_directories(dir, 0750);
    files::check_regular(file, std::uint64_t{1} << 40);
  } catch (const files::FileError& e) {
    throw StoreError(e.what());
  }
  DirLock lock(dir);
  const fs::path copy = dir / "import.db";
  std::error_code ec;
  fs::remove(copy, ec);
  if (!fs::copy_file(file, copy, ec) || ec)
    throw StoreError(fmt::format("{}: cannot copy it into {}: {}", file.string(), dir.string(), ec.message()));
  try {
    sqlite::Connection db(copy, false);
    const std::int64_t app = db.query_int("PRAGMA application_id", "read the application id");
    const std::int64_t version = db.query_int("PRAGMA user_version", "read the schema version");
    if (app != kApplicationId) throw StoreError(fmt::format("{}: is not a sculpt exported by sculptd", file.string()));
    if (version != kSchemaVersion)
      throw StoreError(fmt::format("{}: sculpt format {}, this sculptd reads {}", file.string(), version, kSchemaVersion));
    sqlite::Statement check(db, "PRAGMA quick_check");
    const std::string verdict = check.step("check the file") ? check.column_text(0) : std::string("no answer");
    if (verdict != "ok") throw StoreError(fmt::format("{}: is damaged ({})", file.string(), verdict));
  } catch (const sqlite::Error& e) {
    fs::remove(copy, ec);
    throw StoreError(fmt::format("{}: cannot be read as a sculpt: {}", file.string(), e.what()));
  } catch (const StoreError&) {
    fs::remove(copy, ec);
    throw;
  }
  const fs::path db = dir / "store.db";
  for (const char* suffix : {"", "-wal", "-shm"}) {
    const fs::path from = db.string() + suffix, to = (dir / "previous.db").string() + suffix;
    fs::remove(to, ec);
    if (fs::exists(from, ec)) fs::rename(from, to, ec);
  }
  fs::rename(copy, db, ec);
  if (ec) throw StoreError(fmt::format("{}: cannot put it in place: {}", db.string(), ec.message()));
}

// Runs `write` unless a recent failure says to wait; turns a disk fault into
// a failed Status and the degraded state, and a success into healthy again.
template <class Write>
Status Store::attempt(std::string_view doing, Write&& write, std::chrono::steady_clock::time_point now) {
  if (health_.degraded && now < retry_at_) {
    const auto wait = std::chrono::duration_cast<std::chrono::milliseconds>(retry_at_ - now);
    return {false, true,
            fmt::format("{}: {} deferred: the store is degraded ({}); next retry in {} ms", db_.file().string(), doing,
                        health_.last_error, wait.count())};
  }
  try {
    write();
    health_.degraded = false;
    health_.last_error.clear();
    return {};
  } catch (const std::exception& e) {  // sqlite::Error, and bad_alloc of a huge snapshot
    health_.degraded = true;
    health_.last_error = e.what();
    ++health_.failures;
    retry_at_ = now + limits_.retry_interval;
    return {false, false, e.what()};
  }
}

void Store::keep_pending(std::span<const RecordView> records) {
  for (const RecordView& r : records) {
    pending_.push_back({r.tick, {r.bytes.begin(), r.bytes.end()}});
    pending_bytes_ += r.bytes.size();
  }
  // Over budget: the oldest go first; their ticks become a recorded gap.
  while (pending_bytes_ > limits_.max_pending_bytes && !pending_.empty()) {
    const Record& r = pending_.front();
    if (!gap_) gap_ = Gap{r.tick, r.tick, 0};
    gap_->last_tick = std::max(gap_->last_tick, r.tick);
    ++gap_->records;
    ++health_.dropped_records;
    pending_bytes_ -= r.bytes.size();
    pending_.pop_front();
  }
  health_.pending_records = pending_.size();
}

// Inside a transaction: the gap if any, the records kept in memory, then
// `records` (the caller's newest).
void Store::write_journal(std::span<const RecordView> records) {
  if (gap_) {
    sqlite::Statement st(db_, "INSERT INTO gap (first_tick, last_tick, records) VALUES (?, ?, ?)");
    st.bind(1, static_cast<std::int64_t>(gap_->first_tick))
        .bind(2, static_cast<std::int64_t>(gap_->last_tick))
        .bind(3, static_cast<std::int64_t>(gap_->records))
        .run("record a journal gap");
  }
  sqlite::Statement st(db_, "INSERT INTO journal (tick, data) VALUES (?, ?)");
  for (const Record& r : pending_) st.bind(1, static_cast<std::int64_t>(r.tick)).bind(2, r.bytes).run("append to the journal");
  for (const RecordView& r : records) st.bind(1, static_cast<std::int64_t>(r.tick)).bind(2, r.bytes).run("append to the journal");
}

// After a commit: what was held in memory is on disk now.
void Store::written() {
  pending_.clear();
  pending_bytes_ = 0;
  gap_.reset();
  health_.pending_records = 0;
}

Status Store::append(std::span<const RecordView> records) {
  Status s = attempt("append", [&] {
    sqlite::Transaction tx(db_);
    write_journal(records);
    tx.commit();
  });
  if (s.ok)
    written();
  else
    keep_pending(records);
  return s;
}

// Inside a transaction: the old snapshots the new one pushes out go first,
// so that a store at its size limit has their pages to reuse; if the insert
// fails, the rollback brings them back.
void Store::insert_snapshot(const PreparedSnapshot& s) {
  sqlite::Statement drop(db_, "DELETE FROM snapshot WHERE id NOT IN (SELECT id FROM snapshot ORDER BY id DESC LIMIT ?)");
  drop.bind(1, static_cast<std::int64_t>(limits_.keep_snapshots - 1)).run("delete old snapshots");
  sqlite::Statement ins(db_, "INSERT INTO snapshot (tick, codec, raw_size, meta, data) VALUES (?, ?, ?, ?, ?)");
  ins.bind(1, static_cast<std::int64_t>(s.tick))
      .bind(2, static_cast<std::int64_t>(limits_.codec))
      .bind(3, static_cast<std::int64_t>(s.raw_size))
      .bind(4, s.meta)
      .bind(5, s.data)
      .run("insert a snapshot");
  const std::int64_t id = sqlite3_last_insert_rowid(db_.handle());
  sqlite::Statement put(db_, "INSERT OR IGNORE INTO blob (key, codec, raw_size, data) VALUES (?, ?, ?, ?)");
  for (const PreparedSnapshot::Blob& b : s.blobs) {
    put.bind(1, b.key)
        .bind(2, static_cast<std::int64_t>(limits_.codec))
        .bind(3, static_cast<std::int64_t>(b.raw_size))
        .bind(4, b.data)
        .run("store a blob");
  }
  sqlite::Statement ref(db_, "INSERT INTO snapshot_blob (snapshot, key) VALUES (?, ?)");
  for (const std::string& key : s.refs) ref.bind(1, id).bind(2, key).run("refer to a blob");
  // The journal up to the oldest snapshot kept is needed by none any more,
  // nor the blobs no snapshot kept refers to.
  db_.exec("DELETE FROM journal WHERE tick <= (SELECT min(tick) FROM snapshot);"
           "DELETE FROM gap WHERE last_tick <= (SELECT min(tick) FROM snapshot);"
           "DELETE FROM snapshot_blob WHERE snapshot NOT IN (SELECT id FROM snapshot);"
           "DELETE FROM blob WHERE key NOT IN (SELECT key FROM snapshot_blob)",
           "delete what the snapshots no longer need");
}

// Copies the WAL into the database and truncates it to zero bytes, so the
// disk holds the snapshot once. Not a failure when it cannot: the commit is
// durable in the WAL already, and SQLite's automatic checkpoint keeps going.
void Store::checkpoint() {
  sqlite3_wal_checkpoint_v2(db_.handle(), nullptr, SQLITE_CHECKPOINT_TRUNCATE, nullptr, nullptr);
}

Status Store::write_snapshot(std::uint64_t tick, std::span<const std::byte> state, std::string_view meta,
                             std::span<const BlobWrite> blobs, std::span<const std::string> refs) {
  const auto now = std::chrono::steady_clock::now();
  // Deferred without encoding anything; the same `now` decides, so an empty write never counts as done.
  if (health_.degraded && now < retry_at_) return attempt("snapshot", [] {}, now);
  std::optional<PreparedSnapshot> prepared;
  Status s = attempt("snapshot", [&] { prepared = prepare_snapshot(tick, state, meta, blobs, refs); });  // bad_alloc
  return s.ok ? write_snapshot(*prepared) : s;
}

PreparedSnapshot Store::prepare_snapshot(std::uint64_t tick, std::span<const std::byte> state, std::string_view meta,
                                         std::span<const BlobWrite> blobs, std::span<const std::string> refs) const {
  // Nothing is written that recover() would refuse to read.
  auto check = [this](std::string_view what, std::uint64_t bytes) {
    if (bytes > limits_.max_decoded_bytes)
      throw StoreError(fmt::format("{}: {} is {} bytes, more than a store holds ({})", db_.file().string(), what, bytes,
                                   limits_.max_decoded_bytes));
  };
  check("the snapshot's state", state.size());
  for (const BlobWrite& b : blobs) check(b.key, b.bytes.size());
  PreparedSnapshot p;
  p.tick = tick;
  p.raw_size = state.size();
  p.data = encode(state, limits_.codec, limits_.zstd_level);
  p.meta = meta;
  for (const BlobWrite& b : blobs) p.blobs.push_back({b.key, b.bytes.size(), encode(b.bytes, limits_.codec, limits_.zstd_level)});
  p.refs.assign(refs.begin(), refs.end());
  return p;
}

Status Store::write_snapshot(const PreparedSnapshot& prepared) {
  Status s = attempt("snapshot", [&] {
    sqlite::Transaction tx(db_);
    write_journal({});
    insert_snapshot(prepared);
    tx.commit();
  });
  if (s.ok) {
    written();
    checkpoint();
  }
  return s;
}

Health Store::health() const { return health_; }

void Store::clear() {
  try {
    sqlite::Transaction tx(db_);
    db_.exec("DELETE FROM snapshot; DELETE FROM journal; DELETE FROM gap; DELETE FROM snapshot_blob; DELETE FROM blob",
             "clear the store");
    tx.commit();
  } catch (const sqlite::Error& e) {
    throw StoreError(e.what());
  }
  pending_.clear();
  pending_bytes_ = 0;
  gap_.reset();
  checkpoint();
}

std::uint64_t Store::drop_journal_after(std::uint64_t tick) {
  try {
    sqlite::Transaction tx(db_);
    sqlite::Statement st(db_, "DELETE FROM journal WHERE tick > ?");
    st.bind(1, static_cast<std::int64_t>(std::min<std::uint64_t>(tick, INT64_MAX))).run("drop the journal's tail");
    const auto n = static_cast<std::uint64_t>(sqlite3_changes64(db_.handle()));
    tx.commit();
    return n;
  } catch (const sqlite::Error&) {
    return 0;
  }
}

void Store::export_copy(const std::filesystem::path& file) {
  try {
    sqlite::Statement st(db_, "VACUUM INTO ?");
    st.bind(1, file.string()).run("copy the store");
  } catch (const sqlite::Error& e) {
    throw StoreError(fmt::format("{}: cannot write a copy to {}: {}", db_.file().string(), file.string(), e.what()));
  }
}

}  // namespace sculpt::store
