// A store is untrusted input: a sculpt made by the code, then altered with
// every checksum the format has recomputed (each zstd frame is encoded
// again; SQLite keeps its own), must be refused by name, fall back to the
// snapshot before it, and leave recovery in control: no crash, memory
// bounded by the history's budget, the replay bounded in ticks and time,
// a stop honoured. A good store still recovers bit for bit.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include "test_paths.hpp"
#include "keeper/journal_codec.hpp"
#include "keeper/keeper.hpp"
#include "keeper/replica.hpp"
#include "sim/state_bytes.hpp"
#include "store/codec.hpp"

namespace sculpt::daemon {
namespace {

using testing::Rig;
namespace fs = std::filesystem;

bool short_run() { return std::getenv("SCULPT_KEEP_SHORT") != nullptr; }

KeeperSettings settings(const fs::path& dir) {
  KeeperSettings s;
  s.dir = dir;
  s.commit_every = std::chrono::milliseconds(5);
  s.snapshot_every = std::chrono::milliseconds(150);
  return s;
}

// The push recording on the default scene, sculpted with a keeper that
// snapshots every 150 ms, run to rest and stopped: made once, copied by
// each test.
struct Made {
  fs::path dir;
  std::uint64_t next_tick = 0, hash = 0;
  std::size_t strokes = 0;
};

const Made& made() {
  static const Made m = [] {
    Made m;
    m.dir = testing::fresh_dir("untrusted-made");
    JournalTap tap;
    Rig rig(&tap, testing::recording_path("push.jsonl"));
    Keeper keeper(settings(m.dir), tap);
    keeper.start_anew();
    keeper.scene_started(rig.bundle(), std::make_shared<const scene::Scene>(rig.sim().scene), 0);
    keeper.start();
    rig.start_at(0);
    while (!rig.recording_done()) {
      rig.run(100);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));  // several snapshots on the way
    }
    rig.run(2000);
    keeper.stop();
    m.next_tick = rig.next_tick();
    m.hash = rig.hash_after(m.next_tick - 1);
    m.strokes = keeper.history().strokes.size();
    return m;
  }();
  return m;
}

fs::path copy_of_made(const std::string& name) {
  const fs::path d = testing::fresh_dir(name);
  for (const char* f : {"store.db", "store.db-wal"})
    if (fs::exists(made().dir / f)) fs::copy_file(made().dir / f, d / f, fs::copy_options::overwrite_existing);
  return d;
}

// The store's database, with SQLite directly (the store is closed).
class Db {
 public:
  explicit Db(const fs::path& dir) { EXPECT_EQ(sqlite3_open((dir / "store.db").c_str(), &db_), SQLITE_OK); }
  ~Db() { sqlite3_close(db_); }
  void exec(const std::string& sql) {
    char* err = nullptr;
    EXPECT_EQ(sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &err), SQLITE_OK) << (err ? err : "");
    sqlite3_free(err);
  }
  struct Snapshot {
    std::int64_t id = 0;
    std::uint64_t tick = 0;
    nlohmann::json meta;
    std::vector<std::byte> state;
  };
  // Newest first.
  std::vector<Snapshot> snapshots() {
    std::vector<Snapshot> out;
    sqlite3_stmt* st = prepare("SELECT id, tick, codec, raw_size, meta, data FROM snapshot ORDER BY id DESC");
    while (sqlite3_step(st) == SQLITE_ROW) {
      Snapshot s;
      s.id = sqlite3_column_int64(st, 0);
      s.tick = static_cast<std::uint64_t>(sqlite3_column_int64(st, 1));
      s.meta = nlohmann::json::parse(reinterpret_cast<const char*>(sqlite3_column_text(st, 4)));
      std::string why;
      const auto* p = static_cast<const std::byte*>(sqlite3_column_blob(st, 5));
      auto state = store::decode({p, static_cast<std::size_t>(sqlite3_column_bytes(st, 5))}, sqlite3_column_int64(st, 2),
                                 static_cast<std::uint64_t>(sqlite3_column_int64(st, 3)), why);
      EXPECT_TRUE(state) << why;
      if (state) s.state = std::move(*state);
      out.push_back(std::move(s));
    }
    sqlite3_finalize(st);
    return out;
  }
  // The snapshot's state and meta replaced, encoded as the store encodes.
  void set_snapshot(std::int64_t id, std::span<const std::byte> state, const nlohmann::json& meta) {
    const auto data = store::encode(state, store::Codec::shuffle4_zstd, 1);
    sqlite3_stmt* st = prepare("UPDATE snapshot SET codec = 2, raw_size = ?, meta = ?, data = ? WHERE id = ?");
    sqlite3_bind_int64(st, 1, static_cast<std::int64_t>(state.size()));
    const std::string text = meta.dump();
    sqlite3_bind_text(st, 2, text.c_str(), static_cast<int>(text.size()), SQLITE_TRANSIENT);
    sqlite3_bind_blob(st, 3, data.data(), static_cast<int>(data.size()), SQLITE_TRANSIENT);
    sqlite3_bind_int64(st, 4, id);
    EXPECT_EQ(sqlite3_step(st), SQLITE_DONE);
    sqlite3_finalize(st);
  }
  void put_blob(const std::string& key, std::span<const std::byte> bytes) {
    const auto data = store::encode(bytes, store::Codec::shuffle4_zstd, 1);
    sqlite3_stmt* st = prepare("INSERT OR REPLACE INTO blob (key, codec, raw_size, data) VALUES (?, 2, ?, ?)");
    sqlite3_bind_text(st, 1, key.c_str(), static_cast<int>(key.size()), SQLITE_TRANSIENT);
    sqlite3_bind_int64(st, 2, static_cast<std::int64_t>(bytes.size()));
    sqlite3_bind_blob(st, 3, data.data(), static_cast<int>(data.size()), SQLITE_TRANSIENT);
    EXPECT_EQ(sqlite3_step(st), SQLITE_DONE);
    sqlite3_finalize(st);
  }
  std::vector<std::byte> blob(const std::string& key) {
    sqlite3_stmt* st = prepare("SELECT codec, raw_size, data FROM blob WHERE key = ?");
    sqlite3_bind_text(st, 1, key.c_str(), static_cast<int>(key.size()), SQLITE_TRANSIENT);
    std::vector<std::byte> out;
    if (sqlite3_step(st) == SQLITE_ROW) {
      std::string why;
      const auto* p = static_cast<const std::byte*>(sqlite3_column_blob(st, 2));
      auto b = store::decode({p, static_cast<std::size_t>(sqlite3_column_bytes(st, 2))}, sqlite3_column_int64(st, 0),
                             static_cast<std::uint64_t>(sqlite3_column_int64(st, 1)), why);
      EXPECT_TRUE(b) << why;
      if (b) out = std::move(*b);
    }
    sqlite3_finalize(st);
    return out;
  }
  void refer(std::int64_t snapshot, const std::string& key) {
    exec("INSERT INTO snapshot_blob (snapshot, key) VALUES (" + std::to_string(snapshot) + ", '" + key + "')");
  }
  void journal(std::uint64_t tick, std::span<const std::byte> bytes) {
    sqlite3_stmt* st = prepare("INSERT INTO journal (tick, data) VALUES (?, ?)");
    sqlite3_bind_int64(st, 1, static_cast<std::int64_t>(tick));
    sqlite3_bind_blob(st, 2, bytes.data(), static_cast<int>(bytes.size()), SQLITE_TRANSIENT);
    EXPECT_EQ(sqlite3_step(st), SQLITE_DONE);
    sqlite3_finalize(st);
  }
  std::int64_t count(const std::string& sql) {
    sqlite3_stmt* st = prepare(sql);
    const std::int64_t n = sqlite3_step(st) == SQLITE_ROW ? sqlite3_column_int64(st, 0) : -1;
    sqlite3_finalize(st);
    return n;
  }

 private:
  sqlite3_stmt* prepare(const std::string& sql) {
    sqlite3_stmt* st = nullptr;
    EXPECT_EQ(sqlite3_prepare_v2(db_, sql.c_str(), -1, &st, nullptr), SQLITE_OK) << sqlite3_errmsg(db_);
    return st;
  }
  sqlite3* db_ = nullptr;
};

struct Outcome {
  std::optional<Recovered> rec;
  std::string log;  // what recovery logged (a refusal of every snapshot is logged)
};

Outcome recover(const KeeperSettings& ks, const std::function<bool()>& stop = {}) {
  JournalTap tap;
  Keeper k(ks, tap);
  ::testing::internal::CaptureStderr();
  Outcome o;
  try {
    o.rec = k.recover(stop);
  } catch (...) {
    ::testing::internal::GetCapturedStderr();
    throw;
  }
  o.log = ::testing::internal::GetCapturedStderr();
  return o;
}
Outcome recover(const fs::path& dir) { return recover(settings(dir)); }

bool says(const std::vector<std::string>& lost, const std::string& word) {
  return std::any_of(lost.begin(), lost.end(), [&](const std::string& l) { return l.find(word) != std::string::npos; });
}
std::string joined(const std::vector<std::string>& lost) {
  std::string out;
  for (const std::string& l : lost) out += l + "\n";
  return out;
}

// The exact sculpt after falling back: the snapshot before and the journal
// after it. (Its history may differ: a stroke open at that snapshot's tick
// is recorded from there on.)
void expect_the_made_sculpt(const Outcome& o) {
  ASSERT_TRUE(o.rec) << o.log;
  EXPECT_EQ(o.rec->next_tick, made().next_tick);
  EXPECT_EQ(o.rec->hash, made().hash);
}

// Where `part` (bytes copied whole into the state) lies in `state`.
std::size_t offset_in(std::span<const std::byte> state, std::span<const std::byte> part) {
  const auto it = std::search(state.begin(), state.end(), part.begin(), part.end());
  EXPECT_NE(it, state.end());
  EXPECT_EQ(std::search(it + 1, state.end(), part.begin(), part.end()), state.end()) << "found twice";
  return static_cast<std::size_t>(it - state.begin());
}

template <class T>
std::span<const std::byte> bytes_of(const std::vector<T>& v) {
  return std::as_bytes(std::span<const T>(v));
}

// A replica built from the made sculpt's bundle, restored to `state`: what
// the state's arrays hold, to find them in its bytes.
struct Opened {
  History history{std::uint64_t{1} << 30};
  std::shared_ptr<const SceneBundle> bundle;
  std::unique_ptr<Replica> replica;
  Opened(const fs::path& dir, const Db::Snapshot& s) {
    Db db(dir);
    bundle = std::make_shared<const SceneBundle>(SceneBundle::from_bytes(db.blob(s.meta.at("bundle").get<std::string>())));
    replica = std::make_unique<Replica>(bundle, load_bundle(*bundle), s.meta.at("scene").get<std::uint32_t>(),
                                        s.meta.at("first_tick").get<std::uint64_t>(), history);
    replica->restore_state(s.state);
  }
};

TEST(KeeperUntrusted, AGoodStoreRecoversBitForBit) {
  const fs::path dir = copy_of_made("good");
  const Outcome o = recover(dir);
  expect_the_made_sculpt(o);
  EXPECT_EQ(o.rec->strokes, made().strokes);
  EXPECT_TRUE(o.rec->lost.empty()) << joined(o.rec->lost);
  Db db(dir);
  EXPECT_GE(db.snapshots().size(), 2u) << "the tests fall back to the one before";
  EXPECT_GT(made().strokes, 0u);
}

// A cone whose apex and base centre join 48 vertices each: more than the
// widest neighbour table, so their springs overflow into the list.
std::string cone_obj() {
  std::string obj = "v 0 0.05 0\nv 0 -0.05 0\n";
  const int ring = 48;
  for (int i = 0; i < ring; ++i) {
    const double a = 2 * M_PI * i / ring;
    obj += fmt::format("v {} -0.05 {}\n", 0.05 * std::cos(a), 0.05 * std::sin(a));
  }
  for (int i = 0; i < ring; ++i) {
    const int p = 3 + i, q = 3 + (i + 1) % ring;
    obj += fmt::format("f 1 {} {}\nf 2 {} {}\n", q, p, p, q);
  }
  return obj;
}

TEST(KeeperUntrusted, AnOverflowSpringOutOfRangeIsRefusedAndTheSnapshotBeforeIsUsed) {
  const fs::path dir = testing::fresh_dir("overflow");
  auto bundle = std::make_shared<SceneBundle>(read_bundle("builtin:default", simloop::SimulationSettings{}));
  bundle->file = "cone.toml";
  bundle->text += "\n[[mesh]]\nname = \"cone\"\nfile = \"cone.obj\"\nmaterial = \"rubber\"\nposition = [0.0, 0.3, 0.0]\n";
  bundle->meshes.push_back({"cone.obj", cone_obj()});
  std::uint64_t next = 0, hash = 0;
  {
    JournalTap tap;
    Rig rig(&tap, "", {}, bundle);
    Keeper keeper(settings(dir), tap);
    keeper.start_anew();
    keeper.scene_started(rig.bundle(), std::make_shared<const scene::Scene>(rig.sim().scene), 0);
    keeper.start();
    rig.start_at(0);
    for (int i = 0; i < 30; ++i) {
      rig.run(20);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    keeper.stop();
    next = rig.next_tick();
    hash = rig.hash_after(next - 1);
  }
  Db db(dir);
  const Db::Snapshot s = db.snapshots().front();
  ASSERT_GE(db.snapshots().size(), 2u);
  Opened opened(dir, s);
  const sim::World<float>& w = opened.replica->world();
  const std::size_t body = w.body_count() - 1;
  const auto& overflow = w.body(body).overflow;
  ASSERT_FALSE(overflow.empty()) << "the cone's apex has more neighbours than the table is wide";
  const std::size_t at = offset_in(s.state, bytes_of(overflow));
  for (const auto& [field, value] : {std::pair{offsetof(sim::kernel::Overflow<float>, j), std::uint32_t{1} << 30},
                                     std::pair{offsetof(sim::kernel::Overflow<float>, i), std::uint32_t{0xfffffff0}}}) {
    std::vector<std::byte> bad = s.state;
    std::memcpy(bad.data() + at + field, &value, sizeof value);
    db.set_snapshot(s.id, bad, s.meta);
    const Outcome o = recover(dir);
    ASSERT_TRUE(o.rec) << o.log;
    EXPECT_EQ(o.rec->next_tick, next);
    EXPECT_EQ(o.rec->hash, hash);
    EXPECT_TRUE(says(o.rec->lost, "skipped the snapshot of tick " + std::to_string(s.tick))) << joined(o.rec->lost);
    EXPECT_TRUE(says(o.rec->lost, "mesh " + std::to_string(body) + ": overflow spring 0 joins vertices"))
        << joined(o.rec->lost);
  }
}

// Random bytes over a mesh's positions, velocities, rest shape and springs:
// refused by name every time, and the snapshot before is used.
TEST(KeeperUntrusted, RandomBytesOverAMeshAreRefusedByName) {
  const fs::path dir = copy_of_made("random-mesh");
  Db db(dir);
  const Db::Snapshot s = db.snapshots().front();
  Opened opened(dir, s);
  const sim::Body<float>& b = opened.replica->world().body(0);
  const std::size_t from = offset_in(s.state, std::as_bytes(b.x.span()));
  const std::size_t to = offset_in(s.state, std::as_bytes(b.rest_length.span())) + b.rest_length.size() * 4;
  for (int seed = 1; seed <= (short_run() ? 6 : 12); ++seed) {
    SCOPED_TRACE(seed);
    std::mt19937 gen(static_cast<std::uint32_t>(seed));
    const std::size_t len = std::uniform_int_distribution<std::size_t>(8, 256)(gen);
    const std::size_t at = std::uniform_int_distribution<std::size_t>(from, to - len)(gen);
    std::vector<std::byte> bad = s.state;
    for (std::size_t i = at; i < at + len; ++i) bad[i] = static_cast<std::byte>(gen() & 0xff);
    db.set_snapshot(s.id, bad, s.meta);
    const Outcome o = recover(dir);
    expect_the_made_sculpt(o);
    EXPECT_TRUE(says(o.rec->lost, "skipped the snapshot of tick " + std::to_string(s.tick) + ": state: "))
        << joined(o.rec->lost);
  }
}

// Random bytes anywhere in the world's state: refused by name, or (bytes a
// world never reads, such as the unused slots of a tool's grab list) a
// world that steps on without blowing up. Never "recovered" and then
// blown up.
TEST(KeeperUntrusted, RandomBytesInTheWorldStateAreRefusedOrStepOnWithoutBlowingUp) {
  const fs::path dir = copy_of_made("random");
  Db::Snapshot s;
  {
    Db db(dir);
    s = db.snapshots().front();
  }
  const ReplicaState parts = split_replica_state(s.state);
  const std::size_t world_at = static_cast<std::size_t>(parts.world.data() - s.state.data());
  int refused = 0, stepped = 0;
  const int seeds = short_run() ? 6 : 12;
  for (int seed = 1; seed <= seeds; ++seed) {
    SCOPED_TRACE(seed);
    std::mt19937 gen(static_cast<std::uint32_t>(seed));
    const std::size_t len = std::uniform_int_distribution<std::size_t>(8, 4096)(gen);
    const std::size_t from =
        world_at + std::uniform_int_distribution<std::size_t>(0, parts.world.size() - len)(gen);
    std::vector<std::byte> bad = s.state;
    for (std::size_t i = from; i < from + len; ++i) bad[i] = static_cast<std::byte>(gen() & 0xff);
    {
      Db db(dir);
      db.set_snapshot(s.id, bad, s.meta);
    }
    const Outcome o = recover(dir);
    ASSERT_TRUE(o.rec) << o.log;
    if (says(o.rec->lost, "skipped the snapshot of tick " + std::to_string(s.tick))) {
      ++refused;
      EXPECT_EQ(o.rec->hash, made().hash);
      continue;
    }
    ++stepped;
    Rig rig(nullptr, "", o.rec->state, std::make_shared<SceneBundle>(*o.rec->bundle));
    rig.start_at(o.rec->next_tick);
    std::uint64_t blowups = 0;
    for (int t = 0; t < 300; ++t) {
      rig.tick();
      blowups += rig.sim().world->stats().blowups;
    }
    EXPECT_EQ(blowups, 0u) << "accepted, then blew up";
  }
  EXPECT_GT(refused, 0) << refused << " refused, " << stepped << " stepped on";
}

TEST(KeeperUntrusted, DriverAndMapperStatesAreCheckedToo) {
  const fs::path dir = copy_of_made("driver");
  Db db(dir);
  const Db::Snapshot s = db.snapshots().front();
  const ReplicaState parts = split_replica_state(s.state);
  // The mapper's first device's `attached` flag; the driver's first tool's scale.
  std::vector<std::byte> bad = s.state;
  bad[static_cast<std::size_t>(parts.mapper.data() - s.state.data()) + 8] = std::byte{7};
  db.set_snapshot(s.id, bad, s.meta);
  Outcome o = recover(dir);
  expect_the_made_sculpt(o);
  EXPECT_TRUE(says(o.rec->lost, "mapper state: device 0 attached is not a flag")) << joined(o.rec->lost);
  // The driver: a count, then each tool's state, whose last field is its scale.
  bad = s.state;
  const double huge = 1e300;
  const std::size_t tool_state = (parts.driver.size() - 8) / 2;
  std::memcpy(bad.data() + (parts.driver.data() - s.state.data()) + 8 + tool_state - 8, &huge, 8);
  db.set_snapshot(s.id, bad, s.meta);
  o = recover(dir);
  expect_the_made_sculpt(o);
  EXPECT_TRUE(says(o.rec->lost, "tool driver state: tool 0: scale 1")) << joined(o.rec->lost);
}

TEST(KeeperUntrusted, ASizeOrTickThatDoesNotFitTheSceneIsRefusedByName) {
  const fs::path dir = copy_of_made("sizes");
  Db db(dir);
  const Db::Snapshot s = db.snapshots().front();
  const std::string skipped = "skipped the snapshot of tick " + std::to_string(s.tick) + ": ";
  std::vector<std::byte> longer = s.state;
  longer.resize(longer.size() + 8);
  db.set_snapshot(s.id, longer, s.meta);
  Outcome o = recover(dir);
  expect_the_made_sculpt(o);
  EXPECT_TRUE(says(o.rec->lost, skipped + "its state is " + std::to_string(longer.size()) + " bytes, the scene's is " +
                                    std::to_string(s.state.size())))
      << joined(o.rec->lost);
  const struct {
    const char* key;
    nlohmann::json value;
    std::string says;
  } metas[] = {
      {"next_tick", s.tick + 1, "its meta is of tick " + std::to_string(s.tick + 1)},
      {"first_tick", std::uint64_t{1} << 63, "its meta's \"first_tick\" is 9223372036854775808, not within"},
      {"first_tick", -3, "its meta's \"first_tick\" is -3, not a count"},
      {"format", 2, "snapshot format 2"},
      {"paused", "yes", "its meta's \"paused\" is \"yes\", not true or false"},
      {"strokes", 5, "its meta's \"strokes\" is not a list"},
      {"scene", 0, "its meta's \"scene\" is 0"},
  };
  for (const auto& m : metas) {
    SCOPED_TRACE(m.key);
    nlohmann::json meta = s.meta;
    meta[m.key] = m.value;
    db.set_snapshot(s.id, s.state, meta);
    o = recover(dir);
    expect_the_made_sculpt(o);
    EXPECT_TRUE(says(o.rec->lost, skipped + m.says)) << joined(o.rec->lost);
  }
  db.set_snapshot(s.id, s.state, "not json");
  o = recover(dir);
  expect_the_made_sculpt(o);
  EXPECT_TRUE(says(o.rec->lost, skipped + "its meta is not a JSON object")) << joined(o.rec->lost);
}

// The bundle's settings as a config file's: every snapshot shares the blob,
// so none is usable, and recovery says so and starts anew.
TEST(KeeperUntrusted, TheBundlesSettingsAreHeldToTheConfigsRanges) {
  const fs::path dir = copy_of_made("bundle");
  std::string key;
  SceneBundle good;
  {
    Db db(dir);
    key = db.snapshots().front().meta.at("bundle").get<std::string>();
    good = SceneBundle::from_bytes(db.blob(key));
  }
  const struct {
    std::function<void(SceneBundle&)> change;
    std::string says;
  } cases[] = {
      {[](SceneBundle& b) { b.settings.ring_capacity = std::size_t{4} << 20; },
       "scene bundle: input ring capacity is 4194304, not within [16, 16384]"},
      {[](SceneBundle& b) { b.settings.ring_capacity = std::size_t{1} << 40; },
       "scene bundle: input ring capacity is 1099511627776"},
      {[](SceneBundle& b) { b.settings.rate_hz = 1e9; }, "scene bundle: rate_hz is 1000000000, not within [1, 100000]"},
      {[](SceneBundle& b) { b.settings.max_scale = 0.5; }, "scene bundle: tools.max_scale is 0.5"},
      {[](SceneBundle& b) { b.text.assign(std::size_t{2} << 20, '#'); }, "the scene text is 2097152 bytes, more than"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.says);
    SceneBundle bad = good;
    c.change(bad);
    {
      Db db(dir);
      db.put_blob(key, bad.bytes());
    }
    const Outcome o = recover(dir);
    EXPECT_FALSE(o.rec);
    EXPECT_NE(o.log.find(c.says), std::string::npos) << o.log;
    EXPECT_NE(o.log.find("has no usable snapshot"), std::string::npos) << o.log;
    EXPECT_NE(o.log.find("cannot be recovered; starting anew"), std::string::npos) << o.log;
  }
}

// One journal record far ahead: the replay stops at it by name (no stepping
// towards it); the store as it was is kept aside and a new one starts from
// the state recovered, so the next recovery is whole again.
TEST(KeeperUntrusted, AJournalRecordFarAheadStopsTheReplayByName) {
  const fs::path dir = copy_of_made("far");
  std::vector<std::byte> mark;
  JournalEntry reached;
  reached.kind = JournalEntry::Kind::reached;
  encode_entry(reached, mark);
  {
    Db db(dir);
    db.journal(std::uint64_t{1} << 62, mark);
  }
  const auto began = std::chrono::steady_clock::now();
  Outcome o = recover(dir);
  EXPECT_LT(std::chrono::steady_clock::now() - began, std::chrono::seconds(60)) << "a hang";
  ASSERT_TRUE(o.rec) << o.log;
  EXPECT_EQ(o.rec->next_tick, made().next_tick);
  EXPECT_EQ(o.rec->hash, made().hash);
  EXPECT_TRUE(says(o.rec->lost, "a journal record of tick 4611686018427387903 is ")) << joined(o.rec->lost);
  EXPECT_TRUE(says(o.rec->lost, "more than the 86400 s")) << joined(o.rec->lost);
  EXPECT_TRUE(says(o.rec->lost, "the journal after it is not replayed")) << joined(o.rec->lost);
  EXPECT_NE(o.log.find("is kept as"), std::string::npos) << o.log;
  o = recover(dir);
  ASSERT_TRUE(o.rec);
  EXPECT_TRUE(o.rec->lost.empty()) << joined(o.rec->lost);
  EXPECT_EQ(o.rec->hash, made().hash);
}

// Within the span but more than the wall clock allows: stopped at the cap,
// exact up to where it got; and a stop asked for ends it.
TEST(KeeperUntrusted, TheReplayIsBoundedInTimeAndStopsWhenAsked) {
  const fs::path dir = copy_of_made("slow");
  std::vector<std::byte> mark;
  JournalEntry reached;
  reached.kind = JournalEntry::Kind::reached;
  encode_entry(reached, mark);
  {
    Db db(dir);
    db.journal(made().next_tick + 20'000'000, mark);  // 5.6 h at 1 kHz: within the span
  }
  const fs::path again = dir.string() + "-again";
  fs::remove_all(again);
  fs::copy(dir, again);
  KeeperSettings ks = settings(dir);
  ks.replay_time_limit = std::chrono::milliseconds(300);
  const auto began = std::chrono::steady_clock::now();
  const Outcome o = recover(ks);
  EXPECT_LT(std::chrono::steady_clock::now() - began, std::chrono::seconds(60)) << "a hang";
  ASSERT_TRUE(o.rec) << o.log;
  EXPECT_TRUE(says(o.rec->lost, "the replay was stopped after 0 s (the cap) at tick")) << joined(o.rec->lost);
  EXPECT_GE(o.rec->next_tick, made().next_tick);
  EXPECT_LT(o.rec->next_tick, made().next_tick + 20'000'000);

  int asked = 0;
  const auto stopped_at = std::chrono::steady_clock::now();
  EXPECT_THROW(recover(settings(again), [&asked] { return ++asked > 50; }), RecoveryStopped);
  EXPECT_LT(std::chrono::steady_clock::now() - stopped_at, std::chrono::seconds(60)) << "a hang";
  EXPECT_GT(asked, 50);
}

TEST(KeeperUntrusted, AnAttachWithABindingNoDeviceHasStopsTheReplayThere) {
  const fs::path dir = copy_of_made("binding");
  JournalEntry attach;
  attach.kind = JournalEntry::Kind::message;
  attach.message = input::InputMessage::attach(0, input::DeviceBinding{});
  std::vector<std::byte> bytes;
  encode_entry(attach, bytes);
  // kind, message kind, slot, then the binding: its axis count first.
  bytes[3] = std::byte{200};
  {
    Db db(dir);
    db.journal(made().next_tick + 10, bytes);
  }
  const Outcome o = recover(dir);
  ASSERT_TRUE(o.rec) << o.log;
  EXPECT_EQ(o.rec->hash, made().hash);
  EXPECT_TRUE(says(o.rec->lost, "is unreadable (binding: 200 axes, at most 16)")) << joined(o.rec->lost);
}

// A stroke as keeper/snapshots.cpp stores it.
std::vector<std::byte> stroke_blob(const Stroke& s) {
  std::vector<std::byte> out;
  sim::StateWriter w(out);
  w.value(s.number), w.value(s.scene), w.value(s.body), w.value(s.summary), w.value(s.vertices);
  w.value(static_cast<std::uint8_t>(s.undone)), w.value(static_cast<std::uint64_t>(s.image_bytes));
  w.array(std::span<const char>(s.mesh.data(), s.mesh.size()));
  w.array(s.blocks), w.array(s.images);
  return out;
}

// The newest snapshot's history replaced by `count` strokes of mesh `body`,
// each holding `blocks` of its blocks (their images as the world has them).
struct History_ {
  std::size_t stroke_bytes = 0;  // Stroke::bytes() of each
};
History_ replace_history(const fs::path& dir, std::size_t count, std::uint32_t body, std::uint32_t blocks,
                         const std::function<void(Stroke&, std::size_t)>& alter = {}) {
  Db db(dir);
  Db::Snapshot s = db.snapshots().front();
  Opened opened(dir, s);
  const sim::World<float>& w = opened.replica->world();
  Stroke st;
  st.scene = s.meta.at("scene").get<std::uint32_t>();
  st.body = body;
  st.mesh = load_bundle(*opened.bundle).meshes[body].name;
  st.summary = {1, 0, 2, 1};
  st.image_bytes = w.block_image_bytes(body);
  for (std::uint32_t k = 0; k < blocks; ++k) {
    st.blocks.push_back(k);
    st.vertices += w.body(body).end_of(k) - w.body(body).begin_of(k);
    std::vector<std::byte> image(st.image_bytes);
    w.block_image(body, k, image);
    st.images.insert(st.images.end(), image.begin(), image.end());
  }
  nlohmann::json keys = nlohmann::json::array();
  db.exec("BEGIN");
  for (std::size_t i = 0; i < count; ++i) {
    Stroke one = st;
    one.number = static_cast<std::uint32_t>(i + 1);
    if (alter) alter(one, i);
    const std::string key = "stroke/test-" + std::to_string(i);
    db.put_blob(key, stroke_blob(one));
    db.refer(s.id, key);
    keys.push_back(key);
  }
  db.exec("COMMIT");
  s.meta["strokes"] = keys;
  s.meta["next_stroke"] = count + 1;
  s.meta["dropped"] = 0;
  db.set_snapshot(s.id, s.state, s.meta);
  return {st.bytes()};
}

std::uint64_t status_kb(const char* field) {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(field, 0) == 0) return std::stoull(line.substr(std::strlen(field)));
  return 0;
}

template <class F>
std::uint64_t peak_growth(F&& f) {
  { std::ofstream("/proc/self/clear_refs") << "5"; }
  const std::uint64_t before = status_kb("VmRSS:");
  f();
  const std::uint64_t peak = status_kb("VmHWM:");
  return peak > before ? (peak - before) << 10 : 0;
}

// Strokes far beyond the budget: only what the budget holds is read (newest
// first), the rest counted as dropped, and recovery's memory grows by the
// budget, not by what the file lists.
TEST(KeeperUntrusted, AHistoryBeyondTheBudgetIsNotBuilt) {
  const fs::path dir = copy_of_made("history");
  const std::size_t count = short_run() ? 1000 : 2000;
  const History_ h = replace_history(dir, count, 0, 6);
  const std::uint64_t listed = count * h.stroke_bytes;
  KeeperSettings ks = settings(dir);
  ks.history_budget = 1u << 20;
  ASSERT_GT(listed, 20 * ks.history_budget);
  const fs::path base = copy_of_made("history-base");
  std::uint64_t baseline = 0, grew = 0;
  {
    Outcome warm = recover(base);  // the same recovery without the strokes, for what it costs anyway
    baseline = peak_growth([&] { warm = recover(base); });
  }
  Outcome o;
  grew = peak_growth([&] { o = recover(ks); });
  ASSERT_TRUE(o.rec) << o.log;
  std::printf("strokes listed: %llu bytes; recovery grew by %llu bytes, %llu without them\n", (unsigned long long)listed, (unsigned long long)grew, (unsigned long long)baseline);
  const std::size_t kept = ks.history_budget / h.stroke_bytes;
  EXPECT_EQ(o.rec->strokes, kept);
  EXPECT_LT(grew, baseline + ks.history_budget + (16u << 20))
      << "listed " << listed << " bytes of strokes; baseline " << baseline;
  // ...and at most max_strokes, whatever the budget.
  ks.history_budget = std::uint64_t{1} << 30;
  ks.max_strokes = 50;
  o = recover(ks);
  ASSERT_TRUE(o.rec) << o.log;
  EXPECT_EQ(o.rec->strokes, 50u);
}

TEST(KeeperUntrusted, AStrokeThatDoesNotFitItsMeshIsRefusedByName) {
  const struct {
    std::function<void(Stroke&, std::size_t)> alter;
    std::string says;
  } cases[] = {
      {[](Stroke& s, std::size_t i) { if (i == 2) s.blocks[1] = 100000; }, "stroke 3: block 100000 of a mesh of"},
      {[](Stroke& s, std::size_t i) { if (i == 1) s.blocks[1] = s.blocks[0]; }, "stroke 2: a block twice"},
      {[](Stroke& s, std::size_t i) { if (i == 0) s.body = 9; }, "stroke 1: mesh 9 of a scene of 3"},
      {[](Stroke& s, std::size_t) { s.mesh = "other"; }, "stroke 1: mesh 0 is \"other\""},
      {[](Stroke& s, std::size_t i) { if (i == 1) s.number = 1; }, "stroke 1 is out of order"},
      {[](Stroke& s, std::size_t i) { if (i == 0) s.undone = true; }, "stroke 2 is done after an undone one"},
      {[](Stroke& s, std::size_t i) {
         if (i == 2) {
           const float nan = std::numeric_limits<float>::quiet_NaN();
           std::memcpy(s.images.data() + 200, &nan, sizeof nan);
         }
       },
       "stroke 3: block 0: "},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.says);
    const fs::path dir = copy_of_made("stroke");
    replace_history(dir, 3, 0, 2, c.alter);
    const Outcome o = recover(dir);
    expect_the_made_sculpt(o);
    EXPECT_TRUE(says(o.rec->lost, c.says)) << joined(o.rec->lost);
  }
}

}  // namespace
}  // namespace sculpt::daemon
