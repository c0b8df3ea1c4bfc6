// Helpers shared by the store tests: a private directory per test, bytes
// that look like a state or a journal record, and direct SQLite access to
// damage a store on purpose.
#pragma once

#include <gtest/gtest.h>
#include <sqlite3.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "files/temp_dir.hpp"
#include "store/store.hpp"
#include "support/read_file.hpp"

namespace sculpt::store::testing {

namespace fs = std::filesystem;

// The sanitized build (ASan + UBSan; meson.build defines SCULPT_SANITIZED_BUILD)
// checks memory safety and undefined behaviour: where a case repeats one path
// thousands of times, it takes fewer of them.
#ifdef SCULPT_SANITIZED_BUILD
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif

// A fresh directory below TMPDIR (or `base`), removed at the end of the test.
struct TempDir : files::TempDir {
  explicit TempDir(const fs::path& base = fs::temp_directory_path()) : files::TempDir("sculpt-store", base) {}
};

// `n` bytes from a seeded generator: incompressible, reproducible.
inline std::vector<std::byte> random_bytes(std::size_t n, std::uint32_t seed) {
  std::mt19937 gen(seed);
  std::vector<std::byte> out(n);
  for (auto& b : out) b = static_cast<std::byte>(gen() & 0xff);
  return out;
}

inline Record record(std::uint64_t tick, std::size_t size = 64) {
  return {tick, random_bytes(size, static_cast<std::uint32_t>(tick))};
}

inline std::vector<RecordView> views(const std::vector<Record>& records) {
  std::vector<RecordView> v;
  for (const Record& r : records) v.push_back({r.tick, r.bytes});
  return v;
}

// Records of ticks [first, last].
inline std::vector<Record> records(std::uint64_t first, std::uint64_t last) {
  std::vector<Record> out;
  for (std::uint64_t t = first; t <= last; ++t) out.push_back(record(t));
  return out;
}

// ASSERT_TRUE(succeeded(store.append(...))) prints the store's error.
inline ::testing::AssertionResult succeeded(const Status& s) {
  if (s.ok) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << s.error;
}

using support::read_file;

inline void write_file(const fs::path& p, const char* data, std::size_t n) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(data, static_cast<std::streamsize>(n));
}

// Runs SQL on a closed store's database with SQLite directly.
inline void raw_sql(const fs::path& db_file, const std::string& sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(db_file.c_str(), &db), SQLITE_OK);
  char* err = nullptr;
  const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err);
  EXPECT_EQ(rc, SQLITE_OK) << (err ? err : "");
  sqlite3_free(err);
  sqlite3_close(db);
}

}  // namespace sculpt::store::testing
