// Store::recover and Store::usage: the read side. Every read is wrapped so a
// damaged page costs what it holds, never the whole recovery.
#include <sys/stat.h>

#include <fmt/format.h>

#include "store/store.hpp"

namespace sculpt::store {
namespace {

struct SnapshotRow {
  std::int64_t id = 0;
  std::uint64_t tick = 0;
};

std::uint64_t bytes_on_disk(const std::filesystem::path& p) {
  struct stat st {};
  return ::stat(p.c_str(), &st) == 0 ? static_cast<std::uint64_t>(st.st_size) : 0;
}

std::vector<SnapshotRow> list_snapshots(sqlite::Connection& db) {
  std::vector<SnapshotRow> rows;
  sqlite::Statement st(db, "SELECT id, tick FROM snapshot ORDER BY id DESC");
  while (st.step("list the snapshots")) rows.push_back({st.column_int(0), static_cast<std::uint64_t>(st.column_int(1))});
  return rows;
}

// Every blob the snapshot refers to; false (with `why`) when one is missing
// or does not decode: the snapshot is unusable then.
bool load_blobs(sqlite::Connection& db, std::int64_t snapshot, Snapshot& snap, std::string& why) {
  sqlite::Statement st(db,
                       "SELECT r.key, b.codec, b.raw_size, b.data FROM snapshot_blob r LEFT JOIN blob b ON b.key = r.key "
                       "WHERE r.snapshot = ?");
  st.bind(1, snapshot);
  while (st.step("read a snapshot's blobs")) {
    const std::string key = st.column_text(0);
    if (st.column_is_null(3)) {
      why = fmt::format("blob {} is missing", key);
      return false;
    }
    auto bytes = decode(st.column_blob(3), st.column_int(1), static_cast<std::uint64_t>(st.column_int(2)), why);
    if (!bytes) {
      why = fmt::format("blob {}: {}", key, why);
      return false;
    }
    snap.blobs.emplace(key, std::move(*bytes));
  }
  return true;
}

// The snapshot decoded, or nullopt with `why`.
std::optional<Snapshot> load_snapshot(sqlite::Connection& db, const SnapshotRow& row, std::string& why) {
  try {
    sqlite::Statement st(db, "SELECT codec, raw_size, meta, data FROM snapshot WHERE id = ?");
    st.bind(1, row.id);
    if (!st.step("read a snapshot")) {
      why = "its row is gone";
      return std::nullopt;
    }
    auto state = decode(st.column_blob(3), st.column_int(0), static_cast<std::uint64_t>(st.column_int(1)), why);
    if (!state) return std::nullopt;
    Snapshot snap{row.tick, std::move(*state), st.column_text(2), {}};
    if (!load_blobs(db, row.id, snap, why)) return std::nullopt;
    return snap;
  } catch (const std::exception& e) {  // a damaged page (SQLITE_CORRUPT), or no memory for the state
    why = e.what();
    return std::nullopt;
  }
}

// Journal records of a tick > `after` (-1: all), in order; a read that fails
// part-way keeps what came before and says where it stopped.
void load_journal(sqlite::Connection& db, std::int64_t after, Recovery& out) {
  try {
    sqlite::Statement st(db, "SELECT tick, data FROM journal WHERE tick > ? ORDER BY tick, seq");
    st.bind(1, after);
    while (st.step("read the journal")) {
      const auto bytes = st.column_blob(1);
      out.journal.push_back({static_cast<std::uint64_t>(st.column_int(0)), {bytes.begin(), bytes.end()}});
    }
  } catch (const std::exception& e) {
    out.lost.push_back(fmt::format("the journal after tick {} could not be read ({}): the state after it is not exact",
                                   out.journal.empty() ? after : static_cast<std::int64_t>(out.journal.back().tick), e.what()));
  }
}

void report_gaps(sqlite::Connection& db, std::int64_t after, Recovery& out) {
  try {
    sqlite::Statement st(db, "SELECT first_tick, last_tick, records FROM gap WHERE last_tick > ? ORDER BY first_tick");
    st.bind(1, after);
    while (st.step("read the journal gaps"))
      out.lost.push_back(fmt::format(
          "{} journal records of ticks {}-{} were never written (the disk was failing): the state after tick {} "
          "is not exact",
          st.column_int(2), st.column_int(0), st.column_int(1), st.column_int(0)));
  } catch (const std::exception& e) {
    out.lost.push_back(fmt::format("the journal gaps could not be read: {}", e.what()));
  }
}

}  // namespace

Recovery Store::recover() {
  Recovery out;
  std::vector<SnapshotRow> rows;
  try {
    rows = list_snapshots(db_);
  } catch (const std::exception& e) {
    out.lost.push_back(fmt::format("the snapshots could not be listed: {}", e.what()));
    return out;
  }
  for (const SnapshotRow& row : rows) {
    std::string why;
    out.snapshot = load_snapshot(db_, row, why);
    if (out.snapshot) break;
    out.lost.push_back(fmt::format("{}: skipped the snapshot of tick {}: {}", db_.file().string(), row.tick, why));
  }
  if (!rows.empty() && !out.snapshot) {
    // The journal alone cannot rebuild the state: the part before the oldest
    // snapshot was deleted with the snapshots it served.
    out.lost.push_back(fmt::format("{}: no snapshot could be decoded; the journal is not used", db_.file().string()));
    return out;
  }
  const std::int64_t after = out.snapshot ? static_cast<std::int64_t>(out.snapshot->tick) : -1;
  load_journal(db_, after, out);
  report_gaps(db_, after, out);
  return out;
}

Usage Store::usage() {
  Usage u;
  try {
    u.snapshots = db_.query_int("SELECT count(*) FROM snapshot", "count the snapshots");
    u.journal_records = db_.query_int("SELECT count(*) FROM journal", "count the journal");
  } catch (const sqlite::Error&) {
    // Sizes still say something about a store that cannot be read.
  }
  u.database_bytes = bytes_on_disk(db_.file());
  u.wal_bytes = bytes_on_disk(db_.file().string() + "-wal");
  return u;
}

}  // namespace sculpt::store
