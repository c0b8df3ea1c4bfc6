// A store file is untrusted input (`sculptd --open` takes one from
// anywhere): every size it declares is held to a cap before anything is
// allocated, every value before it is loaded, and what does not fit is
// refused by name, as damage. Memory is measured as the growth of the
// process's peak resident size (VmHWM, reset through /proc/self/clear_refs).
#include <gtest/gtest.h>
#include <zstd.h>

#include <cstring>
#include <fstream>
#include <string>

#include "test_records.hpp"

namespace sculpt::store::testing {
namespace {

std::uint64_t status_kb(const char* field) {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(field, 0) == 0) return std::stoull(line.substr(std::strlen(field)));
  return 0;
}

// How much the peak resident size grew while f ran.
template <class F>
std::uint64_t peak_growth(F&& f) {
  { std::ofstream("/proc/self/clear_refs") << "5"; }  // the peak starts again from the current size
  const std::uint64_t before = status_kb("VmRSS:");
  f();
  const std::uint64_t peak = status_kb("VmHWM:");
  return peak > before ? (peak - before) << 10 : 0;
}

constexpr std::uint64_t MiB = std::uint64_t{1} << 20;

// A zstd frame header that declares `size` bytes (an 8-byte content size,
// the checksum flag set), then one empty last block and a checksum: what a
// file may say without holding it.
std::vector<std::byte> frame_declaring(std::uint64_t size) {
  std::vector<std::byte> f;
  auto put = [&f](unsigned v) { f.push_back(static_cast<std::byte>(v)); };
  for (unsigned v : {0x28u, 0xB5u, 0x2Fu, 0xFDu}) put(v);
  put(0xC4);  // 8-byte content size, not single segment, checksum
  put(0x38);  // window 128 KiB
  for (int i = 0; i < 8; ++i) put(static_cast<unsigned>(size >> (8 * i)) & 0xff);
  for (unsigned v : {0x01u, 0x00u, 0x00u}) put(v);  // last block, raw, empty
  for (int i = 0; i < 4; ++i) put(0);
  return f;
}

bool has(const std::vector<std::string>& lost, const std::string& word) {
  for (const std::string& l : lost)
    if (l.find(word) != std::string::npos) return true;
  return false;
}

std::string joined(const std::vector<std::string>& lost) {
  std::string out;
  for (const std::string& l : lost) out += l + "\n";
  return out;
}

TEST(Codec, ASizeOverTheCapIsRefusedBeforeAnythingIsAllocated) {
  const std::uint64_t three_gib = std::uint64_t{3} << 30;
  const auto frame = frame_declaring(three_gib);
  std::string why;
  std::optional<std::vector<std::byte>> out;
  const std::uint64_t grew = peak_growth([&] { out = decode(frame, 1, three_gib, why); });
  EXPECT_FALSE(out);
  EXPECT_NE(why.find("3221225472 bytes, more than the cap of 1073741824"), std::string::npos) << why;
  EXPECT_LT(grew, 32 * MiB);
}

TEST(Codec, ABombIsStoppedAtItsCapAndDecodedInOneBuffer) {
  const std::vector<std::byte> zeros(64 * MiB);
  for (const Codec codec : {Codec::zstd, Codec::shuffle4_zstd}) {
    const auto blob = encode(zeros, codec, 1);
    ASSERT_LT(blob.size(), 64u << 10) << "64 MiB of zeros compress to almost nothing";
    std::string why;
    EXPECT_FALSE(decode(blob, static_cast<std::int64_t>(codec), zeros.size(), why, 16 * MiB));
    EXPECT_NE(why.find("more than the cap of 16777216"), std::string::npos) << why;
    // Within the cap: one buffer of the declared size, the shuffle undone in
    // it (no second copy of the state).
    std::optional<std::vector<std::byte>> out;
    const std::uint64_t grew = peak_growth([&] { out = decode(blob, static_cast<std::int64_t>(codec), zeros.size(), why); });
    ASSERT_TRUE(out) << why;
    EXPECT_EQ(*out, zeros);
    EXPECT_LT(grew, 96 * MiB) << codec_name(codec);
  }
}

TEST(Codec, FramesThatLieAreRefusedByName) {
  const auto raw = random_bytes(5000, 9);
  const auto good = encode(raw, Codec::shuffle4_zstd, 1);
  std::string why;
  // Cut short, and with bytes after it.
  std::vector<std::byte> cut(good.begin(), good.end() - 100);
  EXPECT_FALSE(decode(cut, 2, raw.size(), why));
  EXPECT_FALSE(why.empty());
  std::vector<std::byte> longer = good;
  longer.resize(longer.size() + 7);
  EXPECT_FALSE(decode(longer, 2, raw.size(), why));
  EXPECT_NE(why.find("7 bytes after the zstd frame"), std::string::npos) << why;
  // A frame that says less than it holds: stopped where it passes its word.
  std::vector<std::byte> big(200'000, std::byte{7});
  auto frame = encode(big, Codec::zstd, 1);
  const unsigned long long declared = ZSTD_getFrameContentSize(frame.data(), frame.size());
  ASSERT_EQ(declared, big.size());
  // The content size is the last field of the header (RFC 8878 3.1.1.1),
  // 4 bytes for this size.
  const unsigned fhd = std::to_integer<unsigned>(frame[4]);
  ASSERT_EQ(fhd >> 6, 2u) << "a 4-byte content size";
  const std::size_t header = 5 + (((fhd >> 5) & 1) ? 0 : 1) + std::size_t{1} * ((fhd & 3) == 3 ? 4 : fhd & 3) + 4;
  const std::uint32_t smaller = 100'000;
  std::memcpy(frame.data() + header - 4, &smaller, 4);
  EXPECT_FALSE(decode(frame, 1, smaller, why));
  EXPECT_FALSE(why.empty());
  // A window larger than any level writes: zstd would allocate it.
  auto wide = frame_declaring(1000);
  wide[5] = std::byte{(31 - 10) << 3};
  EXPECT_FALSE(decode(wide, 1, 1000, why));
  EXPECT_FALSE(why.empty());
}

TEST(StoreUntrusted, ALongMetaAKeyOrTooManyRefsSkipTheSnapshotByName) {
  TempDir dir;
  Limits limits;
  limits.max_meta_bytes = 100;
  limits.max_key_bytes = 8;
  limits.max_blob_refs = 2;
  const auto a = random_bytes(100, 1);
  {
    Store s = Store::open(dir.path(), limits);
    ASSERT_TRUE(succeeded(s.write_snapshot(1, random_bytes(100, 2), "good")));
    ASSERT_TRUE(succeeded(s.write_snapshot(2, random_bytes(100, 3), std::string(200, 'm'))));
    const std::vector<BlobWrite> blobs{{"a", a}, {"b", a}, {"c", a}};
    const std::vector<std::string> three{"a", "b", "c"};
    ASSERT_TRUE(succeeded(s.write_snapshot(3, random_bytes(100, 4), "refs", blobs, three)));
    const std::vector<BlobWrite> long_key{{"a-long-key", a}};
    const std::vector<std::string> one{"a-long-key"};
    ASSERT_TRUE(succeeded(s.write_snapshot(4, random_bytes(100, 5), "key", long_key, one)));
  }
  limits.keep_snapshots = 8;
  Store s = Store::open(dir.path(), limits);
  const Recovery r = s.recover();
  EXPECT_FALSE(r.snapshot) << "only three are kept: the good one is gone";
  EXPECT_TRUE(has(r.lost, "skipped the snapshot of tick 4: it refers to a blob key longer than the cap of 8 bytes"))
      << joined(r.lost);
  EXPECT_TRUE(has(r.lost, "skipped the snapshot of tick 3: it refers to more than 2 blobs")) << joined(r.lost);
  EXPECT_TRUE(has(r.lost, "skipped the snapshot of tick 2: its meta is longer than the cap of 100 bytes"))
      << joined(r.lost);
}

TEST(StoreUntrusted, ANegativeTickOrSizeIsRefusedByName) {
  TempDir dir;
  const auto state = random_bytes(1000, 1);
  {
    Store s = Store::open(dir.path());
    ASSERT_TRUE(succeeded(s.write_snapshot(5, state)));
    ASSERT_TRUE(succeeded(s.write_snapshot(9, state)));
    ASSERT_TRUE(succeeded(s.write_snapshot(12, state)));
  }
  raw_sql(dir.path() / "store.db",
          "UPDATE snapshot SET tick = -7 WHERE tick = 12; UPDATE snapshot SET raw_size = -1 WHERE tick = 9");
  Store s = Store::open(dir.path());
  const Recovery r = s.recover();
  ASSERT_TRUE(r.snapshot);
  EXPECT_EQ(r.snapshot->tick, 5u);
  EXPECT_TRUE(has(r.lost, "skipped a snapshot of tick -7: a tick is never negative")) << joined(r.lost);
  EXPECT_TRUE(has(r.lost, "skipped the snapshot of tick 9: its state is 18446744073709551615 bytes, more than the cap"))
      << joined(r.lost);
}

TEST(StoreUntrusted, TheJournalIsReadWithinItsCaps) {
  TempDir dir;
  Limits limits;
  limits.max_record_bytes = 100;
  limits.max_journal_records = 30;
  limits.max_journal_bytes = 64 * 25;
  {
    Store s = Store::open(dir.path(), limits);
    ASSERT_TRUE(succeeded(s.write_snapshot(10, random_bytes(100, 1))));
    ASSERT_TRUE(succeeded(s.append(views(records(11, 20)))));
    std::vector<Record> big{record(21, 200)};
    ASSERT_TRUE(succeeded(s.append(views(big))));
    ASSERT_TRUE(succeeded(s.append(views(records(22, 30)))));
  }
  {
    Store s = Store::open(dir.path(), limits);
    const Recovery r = s.recover();
    EXPECT_EQ(r.journal, records(11, 20)) << "up to the record over its cap";
    EXPECT_TRUE(has(r.lost, "the journal after tick 20 holds a record")) << joined(r.lost);
    EXPECT_TRUE(has(r.lost, "the cap of 100")) << joined(r.lost);
  }
  raw_sql(dir.path() / "store.db", "DELETE FROM journal WHERE tick = 21");
  {
    limits.max_record_bytes = 64;
    Store s = Store::open(dir.path(), limits);
    const Recovery r = s.recover();
    std::vector<Record> all = records(11, 20);
    for (const Record& x : records(22, 30)) all.push_back(x);
    EXPECT_EQ(r.journal, all) << "within the caps: all of it";
  }
  TempDir many;
  limits.max_journal_bytes = 64 * 1000;
  {
    Store s = Store::open(many.path(), limits);
    ASSERT_TRUE(succeeded(s.write_snapshot(10, random_bytes(100, 1))));
    ASSERT_TRUE(succeeded(s.append(views(records(11, 100)))));
    const Recovery r = s.recover();
    EXPECT_EQ(r.journal.size(), 30u);
    EXPECT_TRUE(has(r.lost, "the journal after tick 40 holds more than 30 records (the cap)")) << joined(r.lost);
  }
  limits.max_journal_records = 1000;
  limits.max_journal_bytes = 64 * 25;
  {
    Store s = Store::open(many.path(), limits);
    const Recovery r = s.recover();
    EXPECT_EQ(r.journal.size(), 25u);
    EXPECT_TRUE(has(r.lost, "holds more than 1600 bytes (the cap)")) << joined(r.lost);
  }
}

TEST(StoreUntrusted, AtMostTheCapOfSnapshotsIsTried) {
  TempDir dir;
  Limits limits;
  limits.keep_snapshots = 10;
  {
    Store s = Store::open(dir.path(), limits);
    for (std::uint64_t t = 1; t <= 6; ++t) ASSERT_TRUE(succeeded(s.write_snapshot(t, random_bytes(100, 1))));
  }
  raw_sql(dir.path() / "store.db", "UPDATE snapshot SET data = zeroblob(10) WHERE tick > 1");
  limits.max_snapshots_tried = 3;
  Store s = Store::open(dir.path(), limits);
  const Recovery r = s.recover();
  EXPECT_FALSE(r.snapshot);
  EXPECT_TRUE(has(r.lost, "holds more snapshots than the 3 tried (the cap)")) << joined(r.lost);
  EXPECT_FALSE(has(r.lost, "tick 3:")) << "tried newest first, three of them";
}

TEST(StoreUntrusted, AJudgeReadsOnlyWhatItAsksForWithinItsOwnCaps) {
  TempDir dir;
  const auto state = random_bytes(5000, 1), blob = random_bytes(3000, 2);
  const std::vector<BlobWrite> blobs{{"k", blob}};
  const std::vector<std::string> refs{"k", "gone"};
  Store s = Store::open(dir.path());
  ASSERT_TRUE(succeeded(s.write_snapshot(3, state, "m", blobs, refs)));
  ASSERT_TRUE(succeeded(s.append(views(records(4, 6)))));
  int judged = 0;
  const Recovery r = s.recover([&](const StoredSnapshot& snap) -> std::string {
    ++judged;
    EXPECT_EQ(snap.raw_size, state.size());
    EXPECT_EQ(snap.blobs.at("k"), blob.size());
    EXPECT_EQ(snap.missing, std::vector<std::string>{"gone"});
    std::string why;
    EXPECT_FALSE(s.read_state(snap, 4999, why));
    EXPECT_NE(why.find("its state is 5000 bytes, more than the cap of 4999"), std::string::npos) << why;
    EXPECT_FALSE(s.read_blob("k", 100, why));
    EXPECT_NE(why.find("blob k is 3000 bytes, more than the cap of 100"), std::string::npos) << why;
    EXPECT_FALSE(s.read_blob("gone", 100, why));
    EXPECT_NE(why.find("blob gone is missing"), std::string::npos) << why;
    const auto got = s.read_state(snap, state.size(), why);
    EXPECT_TRUE(got && *got == state) << why;
    return {};
  });
  EXPECT_EQ(judged, 1);
  ASSERT_TRUE(r.snapshot);
  EXPECT_EQ(r.snapshot->meta, "m");
  EXPECT_TRUE(r.snapshot->state.empty()) << "the judge read what it needed";
  EXPECT_EQ(r.journal, records(4, 6));
}

TEST(StoreUntrusted, NothingIsWrittenThatRecoveryWouldNotRead) {
  TempDir dir;
  Limits limits;
  limits.max_decoded_bytes = 1000;
  Store s = Store::open(dir.path(), limits);
  const Status st = s.write_snapshot(1, random_bytes(1001, 1));
  EXPECT_FALSE(st.ok);
  EXPECT_NE(st.error.find("the snapshot's state is 1001 bytes, more than a store holds (1000)"), std::string::npos)
      << st.error;
  EXPECT_THROW(s.prepare_snapshot(1, random_bytes(10, 1), "", std::vector<BlobWrite>{{"b", random_bytes(2000, 2)}}, {}),
               StoreError);
}

TEST(StoreUntrusted, ManyGapsAreCountedNotListed) {
  TempDir dir;
  {
    Store s = Store::open(dir.path());
    ASSERT_TRUE(succeeded(s.write_snapshot(1, random_bytes(100, 1))));
  }
  std::string sql;
  for (int i = 0; i < 40; ++i) sql += "INSERT INTO gap VALUES (" + std::to_string(10 + i) + ", 100, 1);";
  raw_sql(dir.path() / "store.db", sql);
  Store s = Store::open(dir.path());
  const Recovery r = s.recover();
  EXPECT_EQ(r.lost.size(), 17u);
  EXPECT_TRUE(has(r.lost, "and 24 more journal gaps")) << joined(r.lost);
}

}  // namespace
}  // namespace sculpt::store::testing
