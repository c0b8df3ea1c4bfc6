#include "store/sqlite.hpp"

#include <fmt/format.h>

#include <utility>

namespace sculpt::store::sqlite {

Connection::Connection(const std::filesystem::path& file, bool create) : file_(file) {
  const int flags = SQLITE_OPEN_READWRITE | (create ? SQLITE_OPEN_CREATE : 0) | SQLITE_OPEN_NOMUTEX;
  const int rc = sqlite3_open_v2(file.c_str(), &db_, flags, nullptr);
  if (rc != SQLITE_OK) {
    // Even a failed open returns a handle that holds the message; close it
    // after the message is taken.
    Error e(rc, fmt::format("{}: cannot open the database: {} ({})", file.string(),
                            db_ ? sqlite3_errmsg(db_) : sqlite3_errstr(rc), sqlite3_errstr(rc)));
    sqlite3_close(db_);
    db_ = nullptr;
    throw e;
  }
  sqlite3_extended_result_codes(db_, 1);
}

Connection::Connection(Connection&& o) noexcept : file_(std::move(o.file_)), db_(std::exchange(o.db_, nullptr)) {}

Connection& Connection::operator=(Connection&& o) noexcept {
  if (this != &o) {
    close();
    file_ = std::move(o.file_);
    db_ = std::exchange(o.db_, nullptr);
  }
  return *this;
}

Connection::~Connection() { close(); }

void Connection::close() {
  // sqlite3_close_v2 defers if a statement is still alive; none should be.
  if (db_) sqlite3_close_v2(std::exchange(db_, nullptr));
}

void Connection::fail(int rc, std::string_view doing) const {
  const char* msg = db_ ? sqlite3_errmsg(db_) : "the database is closed";
  // The extended code's name says more than the message for I/O errors
  // ("disk I/O error" is every one of them).
  throw Error(rc, fmt::format("{}: {}: {} (SQLite error {}: {})", file_.string(), doing, msg, rc, sqlite3_errstr(rc)));
}

void Connection::exec(std::string_view sql, std::string_view doing) {
  if (!db_) fail(SQLITE_MISUSE, doing);
  const std::string s(sql);
  const int rc = sqlite3_exec(db_, s.c_str(), nullptr, nullptr, nullptr);
  if (rc != SQLITE_OK) fail(sqlite3_extended_errcode(db_), doing);
}

std::int64_t Connection::query_int(std::string_view sql, std::string_view doing) {
  Statement st(*this, sql);
  if (!st.step(doing)) return 0;
  return st.column_int(0);
}

Statement::Statement(Connection& db, std::string_view sql) : db_(db) {
  if (!db.handle()) db.fail(SQLITE_MISUSE, fmt::format("prepare \"{}\"", sql));
  const int rc = sqlite3_prepare_v2(db.handle(), sql.data(), static_cast<int>(sql.size()), &stmt_, nullptr);
  if (rc != SQLITE_OK) db.fail(sqlite3_extended_errcode(db.handle()), fmt::format("prepare \"{}\"", sql));
}

Statement::~Statement() { sqlite3_finalize(stmt_); }

Statement& Statement::bind(int i, std::int64_t v) {
  sqlite3_bind_int64(stmt_, i, v);
  return *this;
}

Statement& Statement::bind(int i, std::span<const std::byte> blob) {
  // SQLITE_STATIC: every caller keeps the bytes alive until the step.
  sqlite3_bind_blob64(stmt_, i, blob.empty() ? "" : static_cast<const void*>(blob.data()), blob.size(), SQLITE_STATIC);
  return *this;
}

Statement& Statement::bind(int i, std::string_view text) {
  sqlite3_bind_text64(stmt_, i, text.empty() ? "" : text.data(), text.size(), SQLITE_STATIC, SQLITE_UTF8);
  return *this;
}

bool Statement::step(std::string_view doing) {
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  const int code = sqlite3_extended_errcode(db_.handle());
  sqlite3_reset(stmt_);
  db_.fail(code, doing);
}

void Statement::reset() {
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
}

std::int64_t Statement::column_int(int i) const { return sqlite3_column_int64(stmt_, i); }

std::span<const std::byte> Statement::column_blob(int i) const {
  const void* p = sqlite3_column_blob(stmt_, i);
  const int n = sqlite3_column_bytes(stmt_, i);
  return {static_cast<const std::byte*>(p), static_cast<std::size_t>(n)};
}

bool Statement::column_is_null(int i) const { return sqlite3_column_type(stmt_, i) == SQLITE_NULL; }

std::string Statement::column_text(int i) const {
  const auto* p = reinterpret_cast<const char*>(sqlite3_column_text(stmt_, i));
  return p ? std::string(p, static_cast<std::size_t>(sqlite3_column_bytes(stmt_, i))) : std::string();
}

Transaction::Transaction(Connection& db) : db_(db) { db_.exec("BEGIN IMMEDIATE", "begin a transaction"); }

Transaction::~Transaction() {
  // A failed statement may already have rolled the transaction back (FULL,
  // IOERR); ROLLBACK then fails harmlessly.
  if (open_) sqlite3_exec(db_.handle(), "ROLLBACK", nullptr, nullptr, nullptr);
}

void Transaction::commit() {
  db_.exec("COMMIT", "commit");
  open_ = false;
}

}  // namespace sculpt::store::sqlite
