// A thin RAII layer over the SQLite C API: a connection, prepared statements
// and one error type that carries SQLite's result code and message. Nothing
// here knows about snapshots or journals (store.hpp does).
#pragma once

#include <sqlite3.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>

namespace sculpt::store::sqlite {

// What failed, with the database's path and SQLite's own words:
// "/var/lib/sculptd/s.db: insert a snapshot: database or disk is full (SQLITE_FULL)".
class Error : public std::runtime_error {
 public:
  Error(int code, const std::string& what) : std::runtime_error(what), code_(code) {}
  int code() const noexcept { return code_; }  // the extended result code

 private:
  int code_;
};

class Statement;

class Connection {
 public:
  // Opens (creating if asked) the database file; throws Error.
  Connection(const std::filesystem::path& file, bool create);
  Connection(Connection&& o) noexcept;
  Connection& operator=(Connection&& o) noexcept;
  Connection(const Connection&) = delete;
  ~Connection();

  const std::filesystem::path& file() const { return file_; }
  sqlite3* handle() const { return db_; }
  // Closes the database now (the last connection of a WAL database copies
  // the WAL into it and deletes the -wal and -shm files by name). Every call
  // after it fails with SQLITE_MISUSE naming the file.
  void close();
  bool is_open() const { return db_ != nullptr; }

  // Runs one or more statements without results; throws Error naming `doing`.
  void exec(std::string_view sql, std::string_view doing);
  // The first column of the first row of a one-value query (a PRAGMA).
  std::int64_t query_int(std::string_view sql, std::string_view doing);
  // "<file>: <doing>: <sqlite message> (<code name>)" for the last error.
  [[noreturn]] void fail(int rc, std::string_view doing) const;

 private:
  std::filesystem::path file_;
  sqlite3* db_ = nullptr;
};

class Statement {
 public:
  Statement(Connection& db, std::string_view sql);
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  ~Statement();

  Statement& bind(int i, std::int64_t v);
  Statement& bind(int i, std::span<const std::byte> blob);
  Statement& bind(int i, std::string_view text);
  // true while there is a row; false when done; throws Error naming `doing`.
  bool step(std::string_view doing);
  void run(std::string_view doing) { step(doing); reset(); }
  void reset();

  std::int64_t column_int(int i) const;
  std::span<const std::byte> column_blob(int i) const;  // valid until the next step
  std::string column_text(int i) const;
  bool column_is_null(int i) const;

 private:
  Connection& db_;
  sqlite3_stmt* stmt_ = nullptr;
};

// While it lives, no value longer than `bytes` is read (or written) on the
// connection: a step that meets one fails with SQLITE_TOOBIG ("string or
// blob too big") before the value is loaded. length() of a blob column does
// not load it.
class LengthLimit {
 public:
  LengthLimit(Connection& db, std::uint64_t bytes)
      : db_(db),
        was_(sqlite3_limit(db.handle(), SQLITE_LIMIT_LENGTH,
                           static_cast<int>(std::min<std::uint64_t>(bytes, 0x7fffffff)))) {}
  LengthLimit(const LengthLimit&) = delete;
  LengthLimit& operator=(const LengthLimit&) = delete;
  ~LengthLimit() { sqlite3_limit(db_.handle(), SQLITE_LIMIT_LENGTH, was_); }

 private:
  Connection& db_;
  int was_;
};

// A transaction that rolls back unless committed (BEGIN IMMEDIATE: the write
// lock is taken up front, so a commit never fails for a reader's sake).
class Transaction {
 public:
  explicit Transaction(Connection& db);
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  ~Transaction();
  void commit();

 private:
  Connection& db_;
  bool open_ = true;
};

}  // namespace sculpt::store::sqlite
