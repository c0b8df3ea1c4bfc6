// The store's writes: the journal, snapshots, a copy for export, each
// through attempt() (a disk fault degrades the store, never the sculpt).
#include "store/store.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <ctime>
#include <utility>

#include <fmt/format.h>

#include "files/regular_file.hpp"

namespace sculpt::store {

// Runs `write` unless a recent failure says to wait; turns a disk fault into
// a failed Status and the degraded state, and a success into healthy again.
template <class Write>
Status Store::attempt(std::string_view doing, Write&& write, std::chrono::steady_clock::time_point now) {
  if (health_.degraded && now < retry_at_) {
    const auto wait = std::chrono::duration_cast<std::chrono::milliseconds>(retry_at_ - now);
    return {false, true,
            fmt::format("{}: {} deferred: the store is degraded ({}); next retry in {} ms", file_.string(), doing,
                        health_.last_error, wait.count())};
  }
  try {
    keep_files_named(now);
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

Status Store::check_files() {
  try {
    keep_files_named(std::chrono::steady_clock::now());
    return {};
  } catch (const std::exception& e) {  // the next write fails and retries as for any disk fault
    return {false, true, e.what()};
  }
}

void Store::record_dropped(std::uint64_t first_tick, std::uint64_t last_tick, std::uint64_t records) {
  if (records == 0) return;
  if (!gap_) gap_ = Gap{first_tick, last_tick, 0};
  gap_->first_tick = std::min(gap_->first_tick, first_tick);
  gap_->last_tick = std::max(gap_->last_tick, last_tick);
  gap_->records += records;
  health_.dropped_records += records;
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
void Store::wal_checkpoint() {
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
    wal_checkpoint();
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
  wal_checkpoint();
}

void Store::export_copy(const std::filesystem::path& file) {
  try {
    // Not synced: whoever keeps the copy syncs it (sculptctl export does);
    // the daemon's own is read and let go within seconds, and a sync would
    // only put its megabytes on the disk for nothing.
    db_.exec("PRAGMA synchronous = OFF", "copy the store without a sync");
    struct Restore {
      sqlite::Connection& db;
      ~Restore() { sqlite3_exec(db.handle(), "PRAGMA synchronous = FULL", nullptr, nullptr, nullptr); }
    } restore{db_};
    sqlite::Statement st(db_, "VACUUM INTO ?");
    st.bind(1, file.string()).run("copy the store");
  } catch (const sqlite::Error& e) {
    throw StoreError(fmt::format("{}: cannot write a copy to {}: {}", file_.string(), file.string(), e.what()));
  }
  if (pending_.empty() && !gap_) return;
  // What the disk refused is held here: the copy gets it too, so an export
  // made while the store cannot be written is the whole sculpt.
  try {
    sqlite::Connection copy(file, false);
    copy.exec("PRAGMA synchronous = OFF", "copy the store without a sync");
    sqlite::Transaction tx(copy);
    if (gap_) {
      sqlite::Statement st(copy, "INSERT INTO gap (first_tick, last_tick, records) VALUES (?, ?, ?)");
      st.bind(1, static_cast<std::int64_t>(gap_->first_tick))
          .bind(2, static_cast<std::int64_t>(gap_->last_tick))
          .bind(3, static_cast<std::int64_t>(gap_->records))
          .run("record a journal gap in the copy");
    }
    sqlite::Statement st(copy, "INSERT INTO journal (tick, data) VALUES (?, ?)");
    for (const Record& r : pending_)
      st.bind(1, static_cast<std::int64_t>(r.tick)).bind(2, r.bytes).run("add the journal held in memory to the copy");
    tx.commit();
  } catch (const sqlite::Error& e) {
    throw StoreError(fmt::format("{}: cannot add the {} journal records held in memory to the copy {}: {}",
                                 file_.string(), pending_.size(), file.string(), e.what()));
  }
}

}  // namespace sculpt::store
