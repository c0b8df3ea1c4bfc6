// daemon/store's costs on a realistic state: a 163 842-vertex sphere being
// sculpted (positions, velocities, rest positions as float32 xyz, plus the
// triangle and neighbour tables as int32), about 15 MB. Prints, per codec,
// the encoded size and the encode/decode time; the full write_snapshot time
// (encode, commit with fsync, WAL checkpoint); the same commit of the raw
// bytes without compression; the journal at 1 kHz x 64-byte records
// committed every 100 ms; and open + recover. Numbers only: it fails (exit 1)
// only when the store fails (a round trip, a snapshot, a commit, a recovery).
//
//   store_bench [DIR]   (default: a fresh directory below TMPDIR; the disk
//                        it is on is what is measured)
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "files/temp_dir.hpp"
#include "store/codec.hpp"
#include "store/sqlite.hpp"
#include "store/store.hpp"

namespace {

namespace fs = std::filesystem;
using namespace sculpt::store;
using Clock = std::chrono::steady_clock;

// What went wrong: a benchmark that cannot produce its figures fails.
int g_failures = 0;

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

template <class T>
void put(std::vector<std::byte>& out, const std::vector<T>& v) {
  const auto* p = reinterpret_cast<const std::byte*>(v.data());
  out.insert(out.end(), p, p + v.size() * sizeof(T));
}

// What a sculpt's state looks like mid-recording: a dented sphere, a tenth
// of the vertices moving near the tool (the rest asleep at exactly zero).
std::vector<std::byte> sculpt_state(std::size_t vertices) {
  std::mt19937 gen(42);
  std::normal_distribution<float> noise(0.0f, 1.0f);
  std::vector<float> rest, pos, vel;
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (std::size_t i = 0; i < vertices; ++i) {  // a Fibonacci sphere, r = 0.1 m
    const double y = 1.0 - 2.0 * (static_cast<double>(i) + 0.5) / static_cast<double>(vertices);
    const double r = std::sqrt(1.0 - y * y), phi = golden * static_cast<double>(i);
    const float p[3] = {static_cast<float>(0.1 * r * std::cos(phi)), static_cast<float>(0.1 * y),
                        static_cast<float>(0.1 * r * std::sin(phi))};
    const bool near_tool = y > 0.8;  // the top cap, about a tenth
    const float dent = near_tool ? static_cast<float>(0.02 * (y - 0.8)) : 0.0f;
    for (int k = 0; k < 3; ++k) {
      rest.push_back(p[k]);
      pos.push_back(p[k] * (1.0f - dent) + 1e-5f * noise(gen));
      vel.push_back(near_tool ? 0.01f * noise(gen) : 0.0f);
    }
  }
  std::vector<std::int32_t> triangles, neighbours;
  // Indices as a sphere's rings give them: a vertex's neighbours sit within
  // about one ring (~400 vertices) of it, in no tidy pattern.
  std::uniform_int_distribution<int> ring(-400, 400);
  const auto near = [&](std::size_t v) {
    return static_cast<std::int32_t>((static_cast<long>(v + vertices) + ring(gen)) % static_cast<long>(vertices));
  };
  for (std::size_t t = 0; t < 2 * vertices - 4; ++t)  // a closed mesh's count
    for (int k = 0; k < 3; ++k) triangles.push_back(k == 0 ? static_cast<std::int32_t>(t / 2) : near(t / 2));
  for (std::size_t v = 0; v < vertices; ++v)  // ELL columns of 8, the last two often empty (-1)
    for (int k = 0; k < 8; ++k) neighbours.push_back(k < 6 || v % 3 == 0 ? near(v) : -1);
  std::vector<std::byte> out;
  put(out, pos), put(out, vel), put(out, rest), put(out, triangles), put(out, neighbours);
  return out;
}

void codecs(const std::vector<std::byte>& state) {
  std::printf("%-16s %5s %12s %7s %10s %10s\n", "codec", "level", "bytes", "ratio", "encode ms", "decode ms");
  std::printf("%-16s %5s %12zu %7.3f %10s %10s\n", "none", "-", state.size(), 1.0, "-", "-");
  for (const Codec c : {Codec::zstd, Codec::shuffle4_zstd})
    for (const int level : {1, 3}) {
      auto t0 = Clock::now();
      const auto blob = encode(state, c, level);
      const double enc = ms_since(t0);
      std::string why;
      t0 = Clock::now();
      const auto back = decode(blob, static_cast<std::int64_t>(c), state.size(), why);
      const double dec = ms_since(t0);
      const bool round_trip = back && *back == state;
      g_failures += !round_trip;
      std::printf("%-16s %5d %12zu %7.3f %10.1f %10.1f%s\n", codec_name(c), level, blob.size(),
                  static_cast<double>(blob.size()) / static_cast<double>(state.size()), enc, dec,
                  round_trip ? "" : "  ROUND TRIP FAILED");
    }
}

// The median of `n` write_snapshot calls on a store using `codec`.
double snapshot_ms(const fs::path& dir, const std::vector<std::byte>& state, Codec codec, int level, int n) {
  Limits limits;
  limits.codec = codec;
  limits.zstd_level = level;
  Store s = Store::open(dir, limits);
  std::vector<double> t;
  for (int i = 0; i < n; ++i) {
    const auto t0 = Clock::now();
    if (!s.write_snapshot(static_cast<std::uint64_t>(i + 1) * 1000, state)) {
      std::printf("snapshot failed\n");
      ++g_failures;
    }
    t.push_back(ms_since(t0));
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

// The raw bytes committed the same way (WAL, synchronous=FULL, one row,
// checkpoint): the disk's share of a snapshot without compression.
double raw_commit_ms(const fs::path& dir, const std::vector<std::byte>& state, int n) {
  fs::create_directories(dir);
  sqlite::Connection db(dir / "raw.db", true);
  db.exec("PRAGMA journal_mode = WAL; PRAGMA synchronous = FULL; CREATE TABLE s (id INTEGER PRIMARY KEY, data BLOB)",
          "set up");
  std::vector<double> t;
  for (int i = 0; i < n; ++i) {
    const auto t0 = Clock::now();
    sqlite::Transaction tx(db);
    db.exec("DELETE FROM s WHERE id < (SELECT max(id) - 1 FROM s)", "prune");
    sqlite::Statement(db, "INSERT INTO s (data) VALUES (?)").bind(1, state).run("insert");
    tx.commit();
    sqlite3_wal_checkpoint_v2(db.handle(), nullptr, SQLITE_CHECKPOINT_TRUNCATE, nullptr, nullptr);
    t.push_back(ms_since(t0));
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

// 1 kHz of 64-byte input records, committed every 100 ms: `seconds` of a
// recording as fast as the disk takes them.
void journal(const fs::path& dir, int seconds) {
  Store s = Store::open(dir);
  std::vector<std::byte> bytes(64, std::byte{0x5a});
  std::vector<RecordView> batch(100);
  std::vector<double> t;
  std::uint64_t tick = 0;
  const auto t0 = Clock::now();
  for (int b = 0; b < seconds * 10; ++b) {
    for (auto& r : batch) r = {++tick, bytes};
    const auto t1 = Clock::now();
    if (!s.append(batch)) {
      std::printf("append failed\n");
      ++g_failures;
    }
    t.push_back(ms_since(t1));
  }
  const double total = ms_since(t0) / 1000.0;
  std::sort(t.begin(), t.end());
  std::printf("journal: %d commits of 100 x 64 B: median %.2f ms, max %.2f ms per commit; %.0f records/s, %.2f MB/s "
              "(needed: 1000 records/s, 0.064 MB/s)\n",
              seconds * 10, t[t.size() / 2], t.back(), static_cast<double>(tick) / total,
              static_cast<double>(tick) * 64 / total / 1e6);
}

void recovery(const fs::path& dir, const std::vector<std::byte>& state) {
  {
    Store s = Store::open(dir);
    if (!s.write_snapshot(1000, state)) {
      std::printf("snapshot failed\n");
      ++g_failures;
    }
    std::vector<std::byte> bytes(64, std::byte{0x33});
    std::vector<RecordView> batch(100);
    std::uint64_t tick = 1000;
    for (int b = 0; b < 600; ++b) {  // a minute of input after the snapshot
      for (auto& r : batch) r = {++tick, bytes};
      if (!s.append(batch)) {
        std::printf("append failed\n");
        ++g_failures;
      }
    }
  }
  const auto t0 = Clock::now();
  Store s = Store::open(dir);
  const double open = ms_since(t0);
  const Recovery r = s.recover();
  std::printf("recovery: open %.1f ms, recover %.1f ms total: snapshot %zu bytes + %zu journal records%s\n", open,
              ms_since(t0), r.snapshot ? r.snapshot->state.size() : 0, r.journal.size(), r.exact() ? "" : " (NOT EXACT)");
  g_failures += !r.exact();
}

}  // namespace

int main(int argc, char** argv) {
  std::optional<sculpt::files::TempDir> scratch;  // unless a directory is given
  if (argc <= 1) scratch.emplace("store-bench");
  const fs::path base = argc > 1 ? fs::path(argv[1]) : scratch->path();
  const std::vector<std::byte> state = sculpt_state(163'842);
  std::printf("state: 163842 vertices, %zu bytes; store in %s\n\n", state.size(), base.c_str());
  codecs(state);
  std::printf("\nthe float arrays alone (positions, velocities, rest: %zu bytes):\n", 163'842 * 9 * sizeof(float));
  codecs({state.begin(), state.begin() + 163'842 * 9 * sizeof(float)});
  std::printf("\nwrite_snapshot (encode + commit + fsync + checkpoint), median of 5:\n");
  std::printf("  raw bytes, no compression (SQLite only): %.1f ms\n", raw_commit_ms(base / "raw", state, 5));
  for (const Codec c : {Codec::zstd, Codec::shuffle4_zstd})
    for (const int level : {1, 3})
      std::printf("  %-14s level %d: %.1f ms\n", codec_name(c), level,
                  snapshot_ms(base / ("snap-" + std::to_string(static_cast<int>(c)) + "-" + std::to_string(level)), state, c, level, 5));
  std::printf("\n");
  journal(base / "journal", 60);
  recovery(base / "recovery", state);
  if (g_failures > 0) {
    std::fprintf(stderr, "store_bench: %d failures (above): the figures are not the store's\n", g_failures);
    return 1;
  }
  return 0;
}
