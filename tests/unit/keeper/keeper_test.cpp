// The keeper against a sculpt run tick by tick as the sim thread runs it:
// its replica ends with the same bits, undo and redo go through the sim
// thread's world and back, and a store copied at any moment (a crash) or
// cut at any commit recovers the exact state of the tick it says.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <random>
#include <tuple>

#include <sys/stat.h>

#include <kj/async.h>

#include "keeper/keeper.hpp"
#include "keeper/replica.hpp"
#include "test_paths.hpp"

namespace sculpt::daemon {
namespace {

using testing::Rig;
namespace fs = std::filesystem;

// The sanitized build's runs: the same cases, fewer of them.
bool short_run() { return std::getenv("SCULPT_KEEP_SHORT") != nullptr; }

KeeperSettings settings(const fs::path& dir) {
  KeeperSettings s;
  s.dir = dir;
  s.commit_every = std::chrono::milliseconds(5);
  s.snapshot_every = std::chrono::milliseconds(150);
  return s;
}

// Rig + keeper, wired as sculptd wires them.
struct Sculpt {
  explicit Sculpt(const fs::path& dir, const std::string& recording = "push.jsonl")
      : Sculpt(dir, recording, settings(dir)) {}
  Sculpt(const fs::path&, const std::string& recording, const KeeperSettings& ks)
      : rig(&tap, testing::recording_path(recording)), keeper(ks, tap) {
    keeper.start_anew();
    keeper.scene_started(rig.bundle(),
                         std::make_shared<const scene::Scene>(rig.sim().scene), 0);
    keeper.start();
    rig.start_at(0);
  }
  JournalTap tap;
  Rig rig;
  Keeper keeper;
};

// Ticks the rig until the promise is fulfilled (the keeper needs the sim
// thread's ticks to apply a history move).
template <class T>
T tick_until(kj::Promise<T>& p, kj::WaitScope& ws, Rig& rig) {
  for (int i = 0; i < 200000 && !p.poll(ws); ++i) {
    rig.tick();
    if (i % 16 == 0) std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  return p.wait(ws);
}

TEST(Replica, EndsWithTheSimThreadsBits) {
  JournalTap tap;
  Rig rig(&tap, testing::recording_path("two_hands.jsonl"));
  rig.start_at(0);
  History history(std::uint64_t{1} << 30);
  Replica replica(rig.bundle(), load_bundle(*rig.bundle()), 1, 0, history);
  for (int round = 0; round < (short_run() ? 10 : 40) && !rig.recording_done(); ++round) {
    rig.run(400);
    while (auto e = tap.entries().try_pop()) ASSERT_EQ(replica.apply(*e), "");
    replica.advance_to(rig.next_tick());
    ASSERT_EQ(replica.world().hash(), rig.hash_after(rig.next_tick() - 1)) << "tick " << rig.next_tick();
  }
  EXPECT_EQ(replica.world().state(), rig.sim().world->state());
  if (!short_run()) {
    EXPECT_FALSE(history.strokes().empty()) << "the recording's presses make strokes";
  }
}

TEST(Keeper, RecoversTheSculptExactlyAfterAStop) {
  const fs::path dir = testing::fresh_dir("stop");
  std::uint64_t next = 0, hash = 0;
  std::size_t strokes = 0;
  {
    Sculpt s(dir);
    while (!s.rig.recording_done()) s.rig.run(100);
    s.rig.run(500);
    s.rig.pause(true);
    s.keeper.stop();
    next = s.rig.next_tick();
    hash = s.rig.hash_after(next - 1);
    strokes = s.keeper.history().strokes.size();
  }
  JournalTap tap;
  Keeper again(settings(dir), tap);
  const std::optional<Recovered> rec = again.recover();
  ASSERT_TRUE(rec);
  EXPECT_TRUE(rec->lost.empty()) << rec->lost.front();
  EXPECT_EQ(rec->next_tick, next);
  EXPECT_EQ(rec->hash, hash);
  EXPECT_TRUE(rec->paused);
  EXPECT_GT(strokes, 0u);
  EXPECT_EQ(rec->strokes, strokes);
}

TEST(Keeper, HistoryIsAskedForAPageAndSaysWhatIsOnEitherSide) {
  const fs::path dir = testing::fresh_dir("history-page");
  Sculpt s(dir, "two_hands.jsonl");
  while (!s.rig.recording_done()) s.rig.run(100);
  s.rig.run(3000);
  s.keeper.stop();
  const HistoryInfo all = s.keeper.history();
  ASSERT_GE(all.strokes.size(), 3u);
  EXPECT_EQ(all.total, all.strokes.size());
  EXPECT_EQ(all.older + all.newer, 0u);
  const HistoryInfo newest = s.keeper.history(0, 1);
  ASSERT_EQ(newest.strokes.size(), 1u);
  EXPECT_EQ(newest.strokes[0].number, all.strokes.back().number);
  EXPECT_EQ(newest.older, all.total - 1);
  EXPECT_EQ(newest.newer, 0u);
  const HistoryInfo second = s.keeper.history(all.strokes[1].number, 1);
  ASSERT_EQ(second.strokes.size(), 1u);
  EXPECT_EQ(second.strokes[0].number, all.strokes[1].number);
  EXPECT_EQ(second.older, 1u);
  EXPECT_EQ(second.newer, all.total - 2);
  const HistoryInfo past = s.keeper.history(all.strokes.back().number + 1, 5);
  EXPECT_TRUE(past.strokes.empty());
  EXPECT_EQ(past.older, all.total);
  EXPECT_EQ(s.keeper.history(0, 100000).strokes.size(), all.strokes.size()) << "a page is at most the keeper's";
}

TEST(Keeper, WhatTheRunBeforeLeftUnsavedIsSaidAtRecovery) {
  const fs::path dir = testing::fresh_dir("marker");
  std::uint64_t next = 0;
  {
    Sculpt s(dir);
    s.rig.run(2000);
    s.keeper.stop();
    next = s.rig.next_tick();
  }
  EXPECT_FALSE(SaveMarker::read(dir)) << "a run that saved everything leaves nothing to say";
  {
    // As a daemon would leave it that ran 3 s past what it got into the
    // store while writes failed, and whose store lost its last second.
    SaveMarker m(dir);
    SaveState st;
    st.pid = 4242;
    st.committed = next + 1000;
    st.ran = next + 4000;
    st.failing_since_ns = 1'800'000'000'000'000'000;
    st.error = "store.db: commit: disk I/O error";
    m.write(st);
  }
  JournalTap tap;
  Keeper again(settings(dir), tap);
  const std::optional<Recovered> rec = again.recover();
  ASSERT_TRUE(rec);
  ASSERT_EQ(rec->lost.size(), 2u);
  EXPECT_NE(rec->lost[0].find("(PID 4242) had committed the sculpt to tick " + std::to_string(next + 999)),
            std::string::npos)
      << rec->lost[0];
  EXPECT_NE(rec->lost[0].find("1.0 s of saved sculpt are missing"), std::string::npos) << rec->lost[0];
  EXPECT_NE(rec->lost[1].find("the store could not be written since 2027-01-15"), std::string::npos) << rec->lost[1];
  EXPECT_NE(rec->lost[1].find("disk I/O error"), std::string::npos) << rec->lost[1];
  EXPECT_NE(rec->lost[1].find("3.0 s of sculpt, held in its memory) were never saved"), std::string::npos)
      << rec->lost[1];
  EXPECT_EQ(rec->loss, "4.0 s of sculpt lost, see below");
  SaveMarker(dir).remove();
}

TEST(Keeper, AReplayStoppedShortKeepsTheStoreAndGoesOnFromWhatItRecovered) {
  const fs::path dir = testing::fresh_dir("stopped");
  KeeperSettings journal_only = settings(dir);  // only the scene's start is a snapshot
  journal_only.snapshot_every = std::chrono::hours(1);
  journal_only.replay_work_per_snapshot = std::chrono::hours(1);
  {
    Sculpt s(dir, "push.jsonl", journal_only);
    s.rig.run(1500);
    s.keeper.stop();
  }
  {
    store::sqlite::Connection db(dir / "store.db", false);
    // The snapshot at exit gone (the scene's start and the whole journal stay), a record in the middle damaged.
    db.exec("DELETE FROM snapshot WHERE id <> (SELECT min(id) FROM snapshot);"
            "UPDATE journal SET data = x'ffffffff' WHERE seq = (SELECT seq FROM journal ORDER BY seq LIMIT 1 "
            "OFFSET (SELECT count(*) / 2 FROM journal))",
            "damage a record");
  }
  std::uint64_t tick = 0, hash = 0;
  {
    JournalTap tap;
    Keeper k(settings(dir), tap);
    const std::optional<Recovered> rec = k.recover();
    ASSERT_TRUE(rec);
    EXPECT_TRUE(rec->replay_stopped);
    ASSERT_FALSE(rec->lost.empty());
    EXPECT_NE(rec->lost[0].find("is unreadable"), std::string::npos) << rec->lost[0];
    EXPECT_NE(rec->lost[0].find("s of sculpt)"), std::string::npos) << "how much: " << rec->lost[0];
    EXPECT_NE(rec->loss.find("s of sculpt lost, see below"), std::string::npos) << rec->loss;
    tick = rec->next_tick;
    hash = rec->hash;
    EXPECT_EQ(store::Store::generations(dir, store::Kept::unrecovered).size(), 1u) << "the store as it was, kept";
  }
  // What the sculpt went on from is the store now: a recovery after it
  // replays nothing of the journal that could not be replayed.
  JournalTap tap;
  Keeper again(settings(dir), tap);
  const std::optional<Recovered> rec = again.recover();
  ASSERT_TRUE(rec);
  EXPECT_TRUE(rec->lost.empty()) << rec->lost.front();
  EXPECT_EQ(rec->loss, "nothing saved was lost");
  EXPECT_EQ(rec->next_tick, tick);
  EXPECT_EQ(rec->hash, hash);
  EXPECT_EQ(rec->replayed, 0u);
}

TEST(Keeper, UndoAllThenRedoAllGivesTheSameBits) {
  const fs::path dir = testing::fresh_dir("undo");
  Sculpt s(dir);
  Rig never(nullptr, testing::recording_path("push.jsonl"));  // the same recording, never undone
  never.start_at(0);
  kj::EventLoop loop;
  kj::WaitScope ws(loop);
  const std::uint64_t untouched = s.rig.sim().world->hash();
  while (!s.rig.recording_done()) s.rig.run(100);
  s.rig.run(3000);  // the ball comes to rest; the tool has let go
  const std::uint64_t sculpted = s.rig.sim().world->hash();

  auto undo = s.keeper.undo(1000);
  const HistoryMoveResult undone = tick_until(undo, ws, s.rig);
  ASSERT_EQ(undone.error, "");
  EXPECT_GT(undone.done, 0u);
  s.rig.run(50);
  EXPECT_EQ(s.rig.sim().world->hash(), untouched) << "every stroke undone: the ball as it was loaded";
  for (const StrokeInfo& st : s.keeper.history().strokes) EXPECT_TRUE(st.undone);

  auto redo = s.keeper.redo(1000);
  const HistoryMoveResult redone = tick_until(redo, ws, s.rig);
  ASSERT_EQ(redone.error, "");
  EXPECT_EQ(redone.done, undone.done);
  s.rig.run(50);
  EXPECT_EQ(s.rig.sim().world->hash(), sculpted);
  never.run(s.rig.next_tick());
  EXPECT_TRUE(s.rig.sim().world->state() == never.sim().world->state()) << "the whole state, as if never undone";

  auto more = s.keeper.redo(1);
  EXPECT_EQ(tick_until(more, ws, s.rig).error, "nothing to redo");
}

TEST(Keeper, UndoWorksAfterARecovery) {
  const fs::path dir = testing::fresh_dir("undo-recovered");
  std::uint64_t untouched = 0;
  {
    Sculpt s(dir);
    untouched = s.rig.sim().world->hash();
    while (!s.rig.recording_done()) s.rig.run(100);
    s.rig.run(3000);
    s.keeper.stop();
  }
  JournalTap tap;
  Keeper keeper(settings(dir), tap);
  std::optional<Recovered> rec = keeper.recover();
  ASSERT_TRUE(rec);
  Rig rig(&tap, "", rec->state, std::make_shared<SceneBundle>(*rec->bundle));
  keeper.scene_started(rec->bundle, nullptr, rec->next_tick, /*recovered=*/true);
  keeper.start();
  rig.start_at(rec->next_tick);
  kj::EventLoop loop;
  kj::WaitScope ws(loop);
  auto undo = keeper.undo(1000);
  const HistoryMoveResult undone = tick_until(undo, ws, rig);
  ASSERT_EQ(undone.error, "");
  rig.run(50);
  EXPECT_EQ(rig.sim().world->hash(), untouched);
}

// The files of a running store copied as they are: what a SIGKILL leaves.
// The two files are copied one after the other; a SIGKILL freezes both at
// one moment. Appends to the WAL while it is copied are what a later kill
// would leave, but a checkpoint between the two copies would pair a
// database of one moment with a WAL of another: the copy is taken again
// until the database did not change under it.
void copy_store(const fs::path& from, const fs::path& to) {
  const auto version = [&] {
    struct stat st {};
    if (::stat((from / "store.db").c_str(), &st) != 0) return std::tuple<std::int64_t, std::int64_t, std::int64_t>{};
    return std::tuple<std::int64_t, std::int64_t, std::int64_t>{st.st_size, st.st_mtim.tv_sec, st.st_mtim.tv_nsec};
  };
  fs::create_directories(to);
  for (;;) {
    const auto before = version();
    for (const char* f : {"store.db", "store.db-wal"}) {
      fs::remove(to / f);
      std::error_code ec;  // the WAL may be gone between the test and the copy
      if (fs::exists(from / f)) fs::copy_file(from / f, to / f, fs::copy_options::overwrite_existing, ec);
    }
    if (version() == before) return;
  }
}

TEST(Keeper, AStoreCopiedAtAnyMomentRecoversTheExactTickItSays) {
  const fs::path dir = testing::fresh_dir("crash");
  std::vector<fs::path> crashes;
  std::mt19937 seeded(2111);
  std::uniform_int_distribution<int> pause_us(0, 3000);
  Sculpt s(dir, "two_hands.jsonl");
  const std::uint64_t untouched = s.rig.sim().world->hash();
  bool recovered_some = false;
  const int copies = short_run() ? 4 : 1000;
  for (int i = 0; !s.rig.recording_done() && static_cast<int>(crashes.size()) < copies; ++i) {
    s.rig.run(50);
    std::this_thread::sleep_for(std::chrono::microseconds(pause_us(seeded)));
    if (i % 12 == 5) {
      crashes.push_back(dir.string() + "-crash-" + std::to_string(i));
      copy_store(dir, crashes.back());
    }
  }
  ASSERT_GE(crashes.size(), short_run() ? 4u : 5u);
  const auto check = [&](const fs::path& c) {
    JournalTap tap;
    Keeper k(settings(c), tap);
    const std::optional<Recovered> rec = k.recover();
    if (!rec) return;  // copied before the journal thread's first commit: nothing to recover
    EXPECT_TRUE(rec->lost.empty()) << c << ": " << rec->lost.front();
    ASSERT_LE(rec->next_tick, s.rig.next_tick());
    // Copied before anything was committed: the scene as loaded.
    EXPECT_EQ(rec->hash, rec->next_tick ? s.rig.hash_after(rec->next_tick - 1) : untouched) << c << " at tick "
                                                                                            << rec->next_tick;
    recovered_some = recovered_some || rec->next_tick > 0;
  };
  for (const fs::path& c : crashes) check(c);
  // A busy machine may have held the journal thread back past every copy:
  // copies until one holds a committed tick.
  const fs::path late = dir.string() + "-crash-late";
  for (int i = 0; !recovered_some && i < 3000; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    fs::remove_all(late);
    copy_store(dir, late);
    check(late);
  }
  EXPECT_TRUE(recovered_some);
}

// WAL frames: a 32-byte header, then per page a 24-byte header and the page.
TEST(Keeper, AJournalCutAtEveryFrameRecoversAPrefixExactly) {
  const fs::path dir = testing::fresh_dir("cut");
  // Only the scene's start is a snapshot: every commit after it stays in the WAL.
  KeeperSettings journal_only = settings(dir);
  journal_only.snapshot_every = std::chrono::hours(1);
  journal_only.replay_work_per_snapshot = std::chrono::hours(1);
  Sculpt s(dir, "pull.jsonl", journal_only);
  const std::uint64_t untouched = s.rig.sim().world->hash();
  for (int i = 0; i < (short_run() ? 20 : 60); ++i) {  // 1-3 s of the recording, a commit every few ticks
    s.rig.run(50);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  // A busy machine may hold the journal thread back: its commits first.
  const auto wal_now = [&dir] {
    std::error_code ec;
    const std::uintmax_t n = fs::file_size(dir / "store.db-wal", ec);
    return ec ? 0 : n;
  };
  for (int i = 0; i < 3000 && wal_now() < 32 + 4 * (4096 + 24); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  const fs::path copy = dir.string() + "-copy";
  copy_store(dir, copy);
  const std::uintmax_t wal = fs::file_size(copy / "store.db-wal");
  ASSERT_GT(wal, 32u);
  // Every frame of the last 30, every 8th before (sanitized: 8, 32): at its boundary, one byte
  // in, in its header, just past it, mid-page (a cut byte by byte, inside a
  // frame, is the store test's: tests/unit/store/crash_test.cpp). Sanitized,
  // at the boundary and mid-page only: SQLite drops a partial frame whole, so
  // every cut inside one recovers the same prefix the same way.
  const std::uintmax_t page = 4096, frame = page + 24, frames = (wal - 32) / frame;
  std::vector<std::uintmax_t> cuts;
  const std::uintmax_t last_frames = short_run() ? 8 : 30, every = short_run() ? 32 : 8;
  for (std::uintmax_t k = 0; k <= frames; ++k) {
    if (k + last_frames < frames && k % every != 0) continue;
    const std::uintmax_t at = 32 + k * frame;
    for (std::uintmax_t d : {0, 1, 23, 24, 25, 2000})
      if (at + d <= wal && (!short_run() || d == 0 || d == 2000)) cuts.push_back(at + d);
  }
  std::uint64_t last = 0;
  for (std::uintmax_t cut : cuts) {
    const fs::path c = dir.string() + "-cut";
    fs::remove_all(c);
    copy_store(copy, c);
    fs::resize_file(c / "store.db-wal", cut);
    JournalTap tap;
    Keeper k(settings(c), tap);
    const std::optional<Recovered> rec = k.recover();
    if (!rec) continue;  // cut before the first snapshot's commit: an empty store
    EXPECT_TRUE(rec->lost.empty()) << cut << ": " << rec->lost.front();
    EXPECT_GE(rec->next_tick, last) << "a longer journal never recovers less";
    last = rec->next_tick;
    // Cut before the first commit after the scene's start: the scene as loaded.
    EXPECT_EQ(rec->hash, rec->next_tick ? s.rig.hash_after(rec->next_tick - 1) : untouched) << "cut at byte " << cut;
  }
  EXPECT_GT(last, 0u);
}

}  // namespace
}  // namespace sculpt::daemon
