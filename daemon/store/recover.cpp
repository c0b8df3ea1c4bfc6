// Store::recover and Store::usage: the read side. Every read is wrapped so a
// damaged page costs what it holds, never the whole recovery; every value is
// held to Limits' caps before it is loaded or decoded (the file may come
// from anywhere).
#include <sys/stat.h>
#include <zstd.h>

#include <fmt/format.h>

#include "store/store.hpp"

namespace sculpt::store {
namespace {

struct SnapshotRow {
  std::int64_t id = 0;
  std::int64_t tick = 0;
};

std::uint64_t bytes_on_disk(const std::filesystem::path& p) {
  struct stat st {};
  return ::stat(p.c_str(), &st) == 0 ? static_cast<std::uint64_t>(st.st_size) : 0;
}

// The newest `most` snapshots (and whether there are more).
std::vector<SnapshotRow> list_snapshots(sqlite::Connection& db, unsigned most, bool& more) {
  std::vector<SnapshotRow> rows;
  sqlite::Statement st(db, "SELECT id, tick FROM snapshot ORDER BY id DESC LIMIT ?");
  st.bind(1, static_cast<std::int64_t>(most) + 1);
  while (st.step("list the snapshots")) rows.push_back({st.column_int(0), st.column_int(1)});
  more = rows.size() > most;
  if (more) rows.pop_back();
  return rows;
}

// A decoded size as a row holds it; a negative one is as impossible as a huge one.
std::uint64_t size_of(std::int64_t stored) {
  return stored < 0 ? UINT64_MAX : static_cast<std::uint64_t>(stored);
}

}  // namespace

// The snapshot's row without its data, and what it refers to; nullopt (with
// `why`) when a value is out of bounds or unreadable.
std::optional<StoredSnapshot> Store::describe(std::int64_t id, std::uint64_t tick, std::string& why) {
  try {
    StoredSnapshot s;
    s.id = id;
    s.tick = tick;
    {
      // The meta text is loaded only within its cap (SQLITE_TOOBIG beyond;
      // the limit counts the SQL text too, so it is set after the prepare).
      sqlite::Statement st(db_, "SELECT raw_size, meta FROM snapshot WHERE id = ?");
      st.bind(1, id);
      sqlite::LengthLimit limit(db_, limits_.max_meta_bytes);
      try {
        if (!st.step("read a snapshot")) {
          why = "its row is gone";
          return std::nullopt;
        }
      } catch (const sqlite::Error& e) {
        if (e.code() != SQLITE_TOOBIG) throw;
        why = fmt::format("its meta is longer than the cap of {} bytes", limits_.max_meta_bytes);
        return std::nullopt;
      }
      s.raw_size = size_of(st.column_int(0));
      s.meta = st.column_text(1);
    }
    sqlite::Statement refs(db_,
                           "SELECT r.key, b.raw_size, b.key IS NULL FROM snapshot_blob r LEFT JOIN blob b ON b.key = r.key "
                           "WHERE r.snapshot = ?");
    refs.bind(1, id);
    sqlite::LengthLimit limit(db_, limits_.max_key_bytes);
    std::uint64_t count = 0;
    try {
      while (refs.step("read a snapshot's blobs")) {
        if (++count > limits_.max_blob_refs) {
          why = fmt::format("it refers to more than {} blobs (the cap)", limits_.max_blob_refs);
          return std::nullopt;
        }
        std::string key = refs.column_text(0);
        if (refs.column_int(2) != 0) s.missing.push_back(std::move(key));
        else s.blobs[std::move(key)] = size_of(refs.column_int(1));
      }
    } catch (const sqlite::Error& e) {
      if (e.code() != SQLITE_TOOBIG) throw;
      why = fmt::format("it refers to a blob key longer than the cap of {} bytes", limits_.max_key_bytes);
      return std::nullopt;
    }
    return s;
  } catch (const std::exception& e) {  // a damaged page (SQLITE_CORRUPT)
    why = e.what();
    return std::nullopt;
  }
}

std::optional<std::vector<std::byte>> Store::read_state(const StoredSnapshot& s, std::uint64_t max_bytes,
                                                        std::string& why) {
  try {
    // Checked before SQLite loads the encoded bytes (a zstd frame is never
    // much larger than what it holds, ZSTD_compressBound).
    const std::uint64_t cap = std::min(max_bytes, limits_.max_decoded_bytes);
    if (s.raw_size > cap) {
      why = fmt::format("its state is {} bytes, more than the cap of {}", s.raw_size, cap);
      return std::nullopt;
    }
    sqlite::Statement st(db_, "SELECT codec, data FROM snapshot WHERE id = ?");
    st.bind(1, s.id);
    sqlite::LengthLimit limit(db_, ZSTD_COMPRESSBOUND(cap) + 64);
    if (!st.step("read a snapshot")) {
      why = "its row is gone";
      return std::nullopt;
    }
    return decode(st.column_blob(1), st.column_int(0), s.raw_size, why, cap);
  } catch (const std::exception& e) {  // a damaged page, an encoding far too long, no memory for the state
    why = e.what();
    return std::nullopt;
  }
}

std::optional<std::vector<std::byte>> Store::read_blob(const std::string& key, std::uint64_t max_bytes,
                                                       std::string& why) {
  try {
    const std::uint64_t cap = std::min(max_bytes, limits_.max_decoded_bytes);
    sqlite::Statement size(db_, "SELECT raw_size FROM blob WHERE key = ?");
    size.bind(1, key);
    if (!size.step("read a blob")) {
      why = fmt::format("blob {} is missing", key);
      return std::nullopt;
    }
    const std::uint64_t raw_size = size_of(size.column_int(0));
    if (raw_size > cap) {
      why = fmt::format("blob {} is {} bytes, more than the cap of {}", key, raw_size, cap);
      return std::nullopt;
    }
    sqlite::Statement st(db_, "SELECT codec, data FROM blob WHERE key = ?");
    st.bind(1, key);
    sqlite::LengthLimit limit(db_, ZSTD_COMPRESSBOUND(cap) + 64);
    if (!st.step("read a blob")) {
      why = fmt::format("blob {} is missing", key);
      return std::nullopt;
    }
    auto bytes = decode(st.column_blob(1), st.column_int(0), raw_size, why, cap);
    if (!bytes) why = fmt::format("blob {}: {}", key, why);
    return bytes;
  } catch (const std::exception& e) {
    why = fmt::format("blob {}: {}", key, e.what());
    return std::nullopt;
  }
}

// Journal records of a tick > `after` (-1: all), in order, within the caps;
// a read that fails or meets a record out of bounds keeps what came before
// and says where it stopped.
void Store::load_journal(std::int64_t after, Recovery& out) {
  std::uint64_t bytes = 0;
  auto stop = [&](const std::string& why) {
    out.lost.push_back(fmt::format("{}: the journal after tick {} {}: the state after it is not exact",
                                   db_.file().string(),
                                   out.journal.empty() ? after : static_cast<std::int64_t>(out.journal.back().tick), why));
  };
  try {
    // No record longer than its cap is loaded (SQLITE_TOOBIG).
    sqlite::Statement st(db_,
                         "SELECT tick, length(data), CASE WHEN length(data) <= ?2 THEN data END FROM journal "
                         "WHERE tick > ?1 ORDER BY tick, seq");
    st.bind(1, after).bind(2, static_cast<std::int64_t>(limits_.max_record_bytes));
    sqlite::LengthLimit limit(db_, limits_.max_record_bytes);
    while (st.step("read the journal")) {
      const std::int64_t tick = st.column_int(0);
      const std::int64_t size = st.column_int(1);
      if (size < 0 || static_cast<std::uint64_t>(size) > limits_.max_record_bytes)
        return stop(fmt::format("holds a record of {} bytes, more than the cap of {}", size, limits_.max_record_bytes));
      if (out.journal.size() >= limits_.max_journal_records)
        return stop(fmt::format("holds more than {} records (the cap)", limits_.max_journal_records));
      if (bytes + static_cast<std::uint64_t>(size) > limits_.max_journal_bytes)
        return stop(fmt::format("holds more than {} bytes (the cap)", limits_.max_journal_bytes));
      bytes += static_cast<std::uint64_t>(size);
      const auto data = st.column_blob(2);
      out.journal.push_back({static_cast<std::uint64_t>(tick), {data.begin(), data.end()}});
    }
  } catch (const sqlite::Error& e) {
    if (e.code() == SQLITE_TOOBIG)
      return stop(fmt::format("holds a record longer than the cap of {} bytes", limits_.max_record_bytes));
    stop(fmt::format("could not be read ({})", e.what()));
  } catch (const std::exception& e) {  // no memory for the records
    stop(fmt::format("could not be read ({})", e.what()));
  }
}

void Store::report_gaps(std::int64_t after, Recovery& out) {
  try {
    sqlite::Statement st(db_, "SELECT first_tick, last_tick, records FROM gap WHERE last_tick > ? ORDER BY first_tick");
    st.bind(1, after);
    unsigned seen = 0;
    while (st.step("read the journal gaps")) {
      if (++seen > limits_.max_gaps_reported) continue;  // counted, not listed
      out.lost.push_back(fmt::format(
          "{} journal records of ticks {}-{} were never written (the disk was failing): the state after tick {} "
          "is not exact",
          st.column_int(2), st.column_int(0), st.column_int(1), st.column_int(0)));
    }
    if (seen > limits_.max_gaps_reported)
      out.lost.push_back(fmt::format("and {} more journal gaps", seen - limits_.max_gaps_reported));
  } catch (const std::exception& e) {
    out.lost.push_back(fmt::format("the journal gaps could not be read: {}", e.what()));
  }
}

Recovery Store::recover(const Judge& judge) {
  Recovery out;
  std::vector<SnapshotRow> rows;
  bool more = false;
  try {
    rows = list_snapshots(db_, std::max(1u, limits_.max_snapshots_tried), more);
  } catch (const std::exception& e) {
    out.lost.push_back(fmt::format("the snapshots could not be listed: {}", e.what()));
    return out;
  }
  for (const SnapshotRow& row : rows) {
    std::string why;
    if (row.tick < 0) {
      out.lost.push_back(fmt::format("{}: skipped a snapshot of tick {}: a tick is never negative", db_.file().string(),
                                     row.tick));
      continue;
    }
    const std::optional<StoredSnapshot> stored = describe(row.id, static_cast<std::uint64_t>(row.tick), why);
    if (stored) why = judge(*stored);
    if (stored && why.empty()) {
      out.snapshot = Snapshot{stored->tick, {}, stored->meta, {}};
      break;
    }
    out.lost.push_back(fmt::format("{}: skipped the snapshot of tick {}: {}", db_.file().string(), row.tick, why));
  }
  if (!out.snapshot && more)
    out.lost.push_back(fmt::format("{}: holds more snapshots than the {} tried (the cap)", db_.file().string(),
                                   limits_.max_snapshots_tried));
  if (!rows.empty() && !out.snapshot) {
    // The journal alone cannot rebuild the state: the part before the oldest
    // snapshot was deleted with the snapshots it served.
    out.lost.push_back(fmt::format("{}: no snapshot could be decoded; the journal is not used", db_.file().string()));
    return out;
  }
  const std::int64_t after = out.snapshot ? static_cast<std::int64_t>(out.snapshot->tick) : -1;
  load_journal(after, out);
  report_gaps(after, out);
  return out;
}

Recovery Store::recover() {
  std::optional<Snapshot> decoded;
  Recovery out = recover([&](const StoredSnapshot& s) -> std::string {
    std::string why;
    if (!s.missing.empty()) return fmt::format("blob {} is missing", s.missing.front());
    auto state = read_state(s, limits_.max_decoded_bytes, why);
    if (!state) return why;
    Snapshot snap{s.tick, std::move(*state), s.meta, {}};
    for (const auto& [key, size] : s.blobs) {
      auto bytes = read_blob(key, limits_.max_decoded_bytes, why);
      if (!bytes) return why;
      snap.blobs.emplace(key, std::move(*bytes));
    }
    decoded = std::move(snap);
    return {};
  });
  if (out.snapshot) out.snapshot = std::move(decoded);
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
