// The store's files: opening, the generations kept, setting aside,
// adopting a candidate, the files taken away and written back. Its writes:
// store_writes.cpp.
#include "store/store.hpp"

#include <fmt/format.h>

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <ctime>
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

namespace fs = std::filesystem;

namespace {

constexpr const char* kDatabase = "store.db";
constexpr const char* kCandidate = "opening.db";
constexpr const char* kRelocating = "relocating.db";
constexpr const char* kSidecars[] = {"-wal", "-shm"};

fs::path with_suffix(const fs::path& p, const char* suffix) { return p.string() + suffix; }

// The database and its -wal and -shm files gone (what is not there is no error).
void remove_database(const fs::path& db) {
  std::error_code ec;
  fs::remove(db, ec);
  for (const char* s : kSidecars) fs::remove(with_suffix(db, s), ec);
}

void sync_dir(const fs::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);  // best effort: the renames are done; a directory that cannot sync is no reason to fail
  ::close(fd);
}

std::string kind_name(Kept kind) { return kind == Kept::previous ? "previous" : "unrecovered"; }

// "<kind>-<YYYYmmdd-HHMMSS>-<n>.db": n from 1, the first free one.
fs::path generation_name(const fs::path& dir, Kept kind) {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  localtime_r(&now, &tm);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", &tm);
  for (int n = 1;; ++n) {
    const fs::path p = dir / fmt::format("{}-{}-{}.db", kind_name(kind), stamp, n);
    std::error_code ec;
    if (!fs::exists(p, ec) && !fs::exists(with_suffix(p, "-wal"), ec)) return p;
  }
}

// Sorts generation names by time, then by their number.
struct GenerationKey {
  std::string stamp;
  long n = 0;
  bool operator<(const GenerationKey& o) const { return stamp != o.stamp ? stamp < o.stamp : n < o.n; }
};

std::optional<GenerationKey> generation_key(const std::string& name, Kept kind) {
  const std::string prefix = kind_name(kind) + "-";
  if (name.rfind(prefix, 0) != 0 || name.size() < prefix.size() + 4 || name.substr(name.size() - 3) != ".db")
    return std::nullopt;
  const std::string middle = name.substr(prefix.size(), name.size() - prefix.size() - 3);
  const auto dash = middle.rfind('-');
  if (dash == std::string::npos || dash + 1 == middle.size()) return std::nullopt;
  const std::string n = middle.substr(dash + 1);
  if (n.find_first_not_of("0123456789") != std::string::npos || n.size() > 9) return std::nullopt;
  return GenerationKey{middle.substr(0, dash), std::stol(n)};
}

// Renames a database with its -wal (SQLite finds "<name>-wal" beside
// "<name>"); the -shm is rebuilt from them. Throws StoreError.
void move_database(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  fs::remove(with_suffix(from, "-shm"), ec);
  if (fs::exists(with_suffix(from, "-wal"), ec)) {
    fs::rename(with_suffix(from, "-wal"), with_suffix(to, "-wal"), ec);
    if (ec) throw StoreError(fmt::format("{}-wal: cannot rename it to {}-wal: {}", from.string(), to.string(), ec.message()));
  }
  fs::rename(from, to, ec);
  if (ec) {
    std::error_code back;
    fs::rename(with_suffix(to, "-wal"), with_suffix(from, "-wal"), back);
    throw StoreError(fmt::format("{}: cannot rename it to {}: {}", from.string(), to.string(), ec.message()));
  }
}

sqlite::Connection open_database(const fs::path& file, const Limits& limits) {
  sqlite::Connection db(file, true);
  check_or_create_schema(db);  // first: a file that is not a store is left as it was
  configure(db, limits);
  return db;
}

}  // namespace

Store::Store(std::unique_ptr<DirLock> lock, fs::path file, sqlite::Connection db, const Limits& limits)
    : lock_(std::move(lock)), dir_(file.parent_path()), file_(std::move(file)), db_(std::move(db)), limits_(limits) {
  limits_.keep_snapshots = std::max(1u, limits_.keep_snapshots);
  remember_files();
}

Store::Store(Store&& o) noexcept
    : lock_(std::move(o.lock_)),
      dir_(std::move(o.dir_)),
      file_(std::move(o.file_)),
      db_(std::move(o.db_)),
      db_id_(o.db_id_),
      wal_id_(o.wal_id_),
      relocate_at_(o.relocate_at_),
      limits_(o.limits_),
      pending_(std::move(o.pending_)),
      pending_bytes_(std::exchange(o.pending_bytes_, 0)),
      gap_(std::exchange(o.gap_, std::nullopt)),
      health_(std::move(o.health_)),
      retry_at_(o.retry_at_) {
  o.file_.clear();
}

Store::~Store() { discard_candidate(); }

// A candidate nobody adopted takes its copy with it.
void Store::discard_candidate() {
  if (lock_ || file_.empty() || file_.filename() != kCandidate) return;
  db_.close();
  remove_database(file_);
  file_.clear();
}

Store Store::open(const fs::path& dir, const Limits& limits) {
  try {
    files::create_directories(dir, 0750);
  } catch (const files::FileError& e) {
    throw StoreError(e.what());
  }
  auto lock = std::make_unique<DirLock>(dir);
  std::error_code ec;
  if (!fs::exists(dir / kDatabase, ec) && fs::exists(dir / kRelocating, ec)) {
    // A daemon ended while it wrote its store back under its name: the
    // copy it made is the store.
    remove_database(dir / kDatabase);
    fs::rename(dir / kRelocating, dir / kDatabase, ec);
  }
  try {
    return Store(std::move(lock), dir / kDatabase, open_database(dir / kDatabase, limits), limits);
  } catch (const sqlite::Error& e) {
    throw StoreError(e.what());
  }
}

Store Store::open_candidate(const fs::path& file) {
  try {
    files::check_regular(file, std::uint64_t{1} << 40);
  } catch (const files::FileError& e) {
    throw StoreError(e.what());
  }
  const fs::path copy = dir_ / kCandidate;
  remove_database(copy);  // a leftover of a start that ended while opening
  std::error_code ec;
  if (!fs::copy_file(file, copy, ec) || ec) {
    remove_database(copy);
    throw StoreError(fmt::format("{}: cannot copy it into {}: {}", file.string(), dir_.string(), ec.message()));
  }
  try {
    sqlite::Connection db(copy, false);
    const std::int64_t app = db.query_int("PRAGMA application_id", "read the application id");
    const std::int64_t version = db.query_int("PRAGMA user_version", "read the schema version");
    if (app != kApplicationId) throw StoreError(fmt::format("{}: is not a sculpt exported by sculptd", file.string()));
    if (version != kSchemaVersion)
      throw StoreError(fmt::format("{}: sculpt format {}, this sculptd reads {}", file.string(), version, kSchemaVersion));
    {
      sqlite::Statement check(db, "PRAGMA quick_check");
      const std::string verdict = check.step("check the file") ? check.column_text(0) : std::string("no answer");
      if (verdict != "ok") throw StoreError(fmt::format("{}: is damaged ({})", file.string(), verdict));
    }
    configure(db, limits_);
    return Store(nullptr, copy, std::move(db), limits_);
  } catch (const sqlite::Error& e) {
    remove_database(copy);
    throw StoreError(fmt::format("{}: cannot be read as a sculpt: {}", file.string(), e.what()));
  } catch (const StoreError&) {
    remove_database(copy);
    throw;
  }
}

std::vector<fs::path> Store::generations(const fs::path& dir, Kept kind) {
  std::vector<std::pair<GenerationKey, fs::path>> found;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec))
    if (auto key = generation_key(entry.path().filename().string(), kind)) found.emplace_back(*key, entry.path());
  std::sort(found.begin(), found.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<fs::path> out;
  for (auto& f : found) out.push_back(std::move(f.second));
  return out;
}

fs::path Store::set_aside(Kept kind) {
  if (!lock_) throw StoreError(fmt::format("{}: a store being opened cannot be set aside", file_.string()));
  if (kind == Kept::previous && holds_nothing()) {
    clear();  // an empty store keeps nothing worth a generation
    return {};
  }
  const fs::path kept = generation_name(dir_, kind);
  db_.close();  // the WAL copied into the file, when it can be
  try {
    move_database(file_, kept);
  } catch (const StoreError&) {
    db_ = open_database(file_, limits_);  // as it was
    throw;
  }
  try {
    db_ = open_database(file_, limits_);
  } catch (const sqlite::Error& e) {
    // Back as it was: nothing is lost for a store that cannot be made anew.
    try {
      move_database(kept, file_);
      db_ = open_database(file_, limits_);
    } catch (const std::exception&) {
    }
    throw StoreError(fmt::format("{}: cannot start a new store: {}", file_.string(), e.what()));
  }
  sync_dir(dir_);
  remember_files();
  pending_.clear();
  pending_bytes_ = 0;
  gap_.reset();
  const std::vector<fs::path> all = generations(dir_, kind);
  for (std::size_t i = 0; i + kKeptGenerations < all.size(); ++i) remove_database(all[i]);
  return kept;
}

fs::path Store::adopt(Store&& candidate, Kept kept_as) {
  if (!lock_ || candidate.lock_ || candidate.dir_ != dir_)
    throw StoreError(fmt::format("{}: only a store opened with open_candidate can be adopted", candidate.file_.string()));
  const bool keep = !holds_nothing();
  const fs::path kept = keep ? generation_name(dir_, kept_as) : fs::path();
  candidate.db_.close();
  db_.close();
  try {
    if (keep) move_database(file_, kept);
    else remove_database(file_);
    move_database(candidate.file_, file_);
  } catch (const StoreError&) {
    if (keep && !fs::exists(file_)) {
      std::error_code ec;
      if (fs::exists(kept, ec)) move_database(kept, file_);
    }
    db_ = open_database(file_, limits_);
    throw;
  }
  candidate.file_.clear();  // consumed: its destructor deletes nothing
  db_ = open_database(file_, limits_);
  sync_dir(dir_);
  remember_files();
  pending_.clear();
  pending_bytes_ = 0;
  gap_.reset();
  if (keep) {
    const std::vector<fs::path> all = generations(dir_, kept_as);
    for (std::size_t i = 0; i + kKeptGenerations < all.size(); ++i) remove_database(all[i]);
  }
  return kept;
}

// True only for a store known to hold no snapshot and no journal: one that
// cannot be read is never taken for empty (it is kept, not deleted).
bool Store::holds_nothing() {
  try {
    return db_.query_int("SELECT (SELECT count(*) FROM snapshot) + (SELECT count(*) FROM journal)",
                         "count what the store holds") == 0;
  } catch (const sqlite::Error&) {
    return false;
  }
}

// --- the files taken away ---------------------------------------------------------

void Store::remember_files() {
  db_id_ = FileId::of_path(file_);
  wal_id_ = FileId::of_path(with_suffix(file_, "-wal"));
}

// What was removed or replaced, or "" when the files are where they were.
std::string Store::files_taken() const {
  const auto what = [](const fs::path& p, const FileId& now, const char* kind) {
    return fmt::format("{} {} {}", kind, p.string(), now.known() ? "was replaced by another file" : "was removed");
  };
  if (!lock_->holds_path()) return what(dir_, FileId::of_path(dir_), "the store's directory");
  const FileId db = FileId::of_path(file_);
  if (db != db_id_) return what(file_, db, "the database");
  if (wal_id_.known()) {
    const FileId wal = FileId::of_path(with_suffix(file_, "-wal"));
    if (wal != wal_id_) return what(with_suffix(file_, "-wal"), wal, "the database's write-ahead log");
  }
  return {};
}

// Before a write: the files are where they were, or are put back. Throws
// (sqlite::Error, StoreError) when they cannot be; the write then fails as
// for any disk fault and is retried.
void Store::keep_files_named(std::chrono::steady_clock::time_point now) {
  if (!lock_) return;  // a candidate
  lock_->restore_file();
  if (!wal_id_.known()) wal_id_ = FileId::of_path(with_suffix(file_, "-wal"));  // made by the first write
  const std::string what = files_taken();
  if (what.empty()) return;
  if (health_.unnamed && now < relocate_at_) return;  // still on the unnamed files; tried again later
  try {
    relocate(what);
  } catch (const StoreInUse& e) {
    // Another daemon took the directory: this store goes on in its unnamed
    // files (they live while open) and is not put back over the other's.
    relocate_at_ = now + limits_.retry_interval;
    if (!health_.unnamed) {
      ++health_.relocations;
      health_.relocation = fmt::format("{}, and {}: this sculpt is kept only in files that no longer have a name "
                                       "(a crash loses it; sculptctl export saves it)",
                                       what, e.what());
    }
    health_.unnamed = true;
  }
}

// Writes the whole store (snapshots, journal, blobs: what the open
// connection still reads) back under its names, and goes on there.
void Store::relocate(const std::string& what) {
  if (!lock_->holds_path()) {
    try {
      files::create_directories(dir_, 0750);
    } catch (const files::FileError& e) {
      throw StoreError(e.what());
    }
    lock_ = std::make_unique<DirLock>(dir_);  // may throw StoreInUse: another daemon got there first
  }
  const fs::path copy = dir_ / kRelocating;
  std::error_code ec;
  if (!db_.is_open()) {
    // A relocation that failed after its close: its copy is all there is.
    if (fs::exists(copy, ec)) fs::rename(copy, file_, ec);
    db_ = open_database(file_, limits_);
    remember_files();
    return;
  }
  remove_database(copy);
  {
    sqlite::Statement st(db_, "VACUUM INTO ?");
    st.bind(1, copy.string()).run("copy the store back under its name");
  }
  // Files that are not this store's keep their names (with a suffix); the
  // close below deletes the -wal and -shm paths, which must be ours by then.
  for (const auto& [path, mine] : {std::pair{file_, db_id_}, std::pair{with_suffix(file_, "-wal"), wal_id_}}) {
    const FileId now = FileId::of_path(path);
    if (now.known() && now != mine) fs::rename(path, with_suffix(path, ".foreign"), ec);
  }
  fs::remove(with_suffix(file_, "-shm"), ec);
  db_.close();
  remove_database(file_);  // what is left of the old names is the copy's past
  fs::rename(copy, file_, ec);
  const fs::path opened = ec ? copy : file_;
  db_ = open_database(opened, limits_);
  file_ = opened;
  sync_dir(dir_);
  remember_files();
  ++health_.relocations;
  health_.unnamed = false;
  health_.relocation = fmt::format("{}: its content was written back to {}", what, file_.string());
}

}  // namespace sculpt::store
