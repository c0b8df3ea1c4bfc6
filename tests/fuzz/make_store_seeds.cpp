// Writes the store fuzzer's seeds (tests/fuzz/store_seeds) from a real
// sculpt: the tiny scene (store_fuzz_base.hpp) sculpted by the start of the
// push recording with a keeper, exactly as sculptd runs it, then exported; and
// inputs of every other mode made from it and from the fuzzer's base.
//
//   build-asan/tests/fuzz/make_store_seeds tests/fuzz/store_seeds
#include <sqlite3.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <thread>

#include "keeper/journal_codec.hpp"
#include "keeper/keeper.hpp"
#include "store/codec.hpp"
#include "store/store.hpp"
#include "store_fuzz_base.hpp"
#include "support/sculpt_rig.hpp"

namespace {

using namespace sculpt;
namespace fs = std::filesystem;

void write(const fs::path& dir, const std::string& name, char mode, std::span<const std::uint8_t> body) {
  std::ofstream out(dir / name, std::ios::binary | std::ios::trunc);
  out.put(mode);
  out.write(reinterpret_cast<const char*>(body.data()), static_cast<std::streamsize>(body.size()));
  std::printf("%s: %zu bytes\n", name.c_str(), body.size() + 1);
}

std::span<const std::uint8_t> u8(std::span<const std::byte> b) {
  return {reinterpret_cast<const std::uint8_t*>(b.data()), b.size()};
}

std::vector<std::uint8_t> read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

template <class T>
void put(std::vector<std::uint8_t>& v, T x) {
  const auto* p = reinterpret_cast<const std::uint8_t*>(&x);
  v.insert(v.end(), p, p + sizeof x);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_store_seeds OUTDIR\n");
    return 2;
  }
  const fs::path out = argv[1];
  fs::create_directories(out);
  const fs::path dir = fs::temp_directory_path() / "sculpt-store-seeds";
  fs::remove_all(dir);

  // The sculpt, as sculptd's threads make it: the scene's start and a last
  // snapshot at the end, with the whole journal between them (an attach,
  // frames, a pause and a resume, the keeper's marks).
  daemon::KeeperSettings ks;
  ks.dir = dir;
  ks.commit_every = std::chrono::milliseconds(5);
  ks.snapshot_every = std::chrono::hours(1);
  ks.replay_work_per_snapshot = std::chrono::hours(1);
  {
    daemon::JournalTap tap;
    daemon::testing::Rig rig(&tap, std::string(SCULPT_TEST_DATA) + "/recordings/push.jsonl", {}, fuzz::tiny_bundle());
    daemon::Keeper keeper(ks, tap);
    keeper.start_anew();
    keeper.scene_started(rig.bundle(), std::make_shared<const scene::Scene>(rig.sim().scene), 0);
    keeper.start();
    rig.start_at(0);
    for (int i = 0; i < 8 && !rig.recording_done(); ++i) {  // the recording's first press (the seed stays small)
      rig.run(200);
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    rig.pause(true);
    rig.pause(false);
    rig.run(10);
    keeper.stop();
  }
  std::vector<store::Record> journal;
  {
    store::Store st = store::Store::open(dir);
    // The journal after the oldest snapshot kept: the longest a recovery replays.
    const std::int64_t kept = st.usage().snapshots;
    std::int64_t offered = 0;
    journal = st.recover([&](const store::StoredSnapshot&) {
                  return ++offered == kept ? std::string() : std::string("not the oldest");
                }).journal;
    st.export_copy(dir / "export.sculpt");
  }
  // Small pages: the same database in fewer bytes (a seed is mutated whole).
  sqlite3* db = nullptr;
  if (sqlite3_open((dir / "export.sculpt").c_str(), &db) != SQLITE_OK ||
      sqlite3_exec(db, "PRAGMA journal_mode = DELETE; PRAGMA page_size = 512; VACUUM", nullptr, nullptr, nullptr) !=
          SQLITE_OK) {
    std::fprintf(stderr, "make_store_seeds: %s\n", sqlite3_errmsg(db));
    return 1;
  }
  sqlite3_close(db);
  write(out, "export", 'F', read_file(dir / "export.sculpt"));

  fuzz::Base base;
  write(out, "base", 'P', {});
  std::vector<std::uint8_t> in;
  const std::string meta = base.meta.dump();
  fuzz::section(in, 'M', {reinterpret_cast<const std::uint8_t*>(meta.data()), meta.size()});
  write(out, "meta", 'P', in);
  in.clear();
  std::vector<std::uint8_t> none;
  put(none, std::uint32_t{0});
  fuzz::section(in, 'K', none);
  write(out, "stroke", 'P', in);
  in.clear();
  fuzz::section(in, 'T', none);
  write(out, "tick", 'P', in);

  // Real journal records: each kind once as 'E', and a run of them as 'J' sections.
  std::map<std::uint8_t, int> kinds;
  in.clear();
  std::size_t sections = 0;
  const std::uint64_t first = journal.empty() ? 0 : journal.front().tick;
  for (const store::Record& r : journal) {
    if (r.bytes.empty()) continue;
    const std::uint8_t kind = std::to_integer<std::uint8_t>(r.bytes[0]);
    const std::uint8_t message = r.bytes.size() > 1 ? std::to_integer<std::uint8_t>(r.bytes[1]) : 0;
    const std::uint8_t key = static_cast<std::uint8_t>(kind * 16 + (kind == 0 ? message : 0));
    if (kinds[key]++ == 0) write(out, "entry-" + std::to_string(key), 'E', u8(r.bytes));
    if (sections < 60 && r.tick - first < 60000) {
      std::vector<std::uint8_t> payload;
      put(payload, static_cast<std::uint16_t>(r.tick - first));
      const auto record = u8(r.bytes);
      payload.insert(payload.end(), record.begin(), record.end());
      fuzz::section(in, 'J', payload);
      ++sections;
    }
  }
  write(out, "journal", 'P', in);

  write(out, "replica", 'R', {});
  in.clear();
  put(in, std::uint32_t{0}), put(in, std::uint32_t{0}), put(in, std::uint32_t{0});
  write(out, "image", 'I', in);
  write(out, "bundle", 'U', u8(base.bundle_bytes));
  in.clear();
  const auto encoded = store::encode(base.bundle_bytes, store::Codec::shuffle4_zstd, 1);
  in.push_back(2);
  put(in, static_cast<std::uint32_t>(base.bundle_bytes.size()));
  const auto frame = u8(encoded);
  in.insert(in.end(), frame.begin(), frame.end());
  write(out, "frame", 'Z', in);
  fs::remove_all(dir);
  return 0;
}
