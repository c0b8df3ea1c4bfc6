#include "log/log.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cinttypes>
#include <cstdio>
#include <cstdlib>

#include "cli/conventions.hpp"

namespace sculpt::log {
namespace {

std::atomic<int> g_level{static_cast<int>(Level::info)};
// -1: decide from the environment at the first message.
std::atomic<int> g_prefix{-1};

// systemd sets JOURNAL_STREAM to "DEVICE:INODE" of the stream it connected
// to stdout/stderr; a child that inherits the variable but writes elsewhere
// (a terminal, a pipe) must not use the prefixes (systemd.exec(5)).
bool stderr_is_journal() {
  const char* env = std::getenv("JOURNAL_STREAM");
  if (env == nullptr) return false;
  std::uintmax_t dev = 0, ino = 0;
  if (std::sscanf(env, "%ju:%ju", &dev, &ino) != 2) return false;
  struct stat st {};
  if (::fstat(STDERR_FILENO, &st) != 0) return false;
  return static_cast<std::uintmax_t>(st.st_dev) == dev && static_cast<std::uintmax_t>(st.st_ino) == ino;
}

bool use_prefix() {
  int p = g_prefix.load(std::memory_order_relaxed);
  if (p < 0) {
    p = stderr_is_journal() ? 1 : 0;
    g_prefix.store(p, std::memory_order_relaxed);
  }
  return p == 1;
}

}  // namespace

void set_level(Level level) { g_level.store(static_cast<int>(level), std::memory_order_relaxed); }
Level level() { return static_cast<Level>(g_level.load(std::memory_order_relaxed)); }
void set_journal_prefix(bool on) { g_prefix.store(on ? 1 : 0, std::memory_order_relaxed); }

bool parse_level(std::string_view name, Level& out) {
  if (name == "err" || name == "error") out = Level::err;
  else if (name == "warning" || name == "warn") out = Level::warning;
  else if (name == "notice") out = Level::notice;
  else if (name == "info") out = Level::info;
  else if (name == "debug") out = Level::debug;
  else return false;
  return true;
}

std::string_view level_name(Level level) {
  switch (level) {
    case Level::err: return "error";
    case Level::warning: return "warning";
    case Level::notice: return "notice";
    case Level::info: return "info";
    case Level::debug: return "debug";
  }
  return "?";
}

void write(Level lvl, std::string_view message) {
  if (static_cast<int>(lvl) > g_level.load(std::memory_order_relaxed)) return;
  std::string line;
  line.reserve(message.size() + 16);
  if (use_prefix()) {
    line += '<';
    line += static_cast<char>('0' + static_cast<int>(lvl));
    line += '>';
  } else {
    // The programs' one voice (cli/conventions.hpp): "sculptd: error: ...".
    line += "sculptd: ";
    if (lvl != Level::info) {
      line += level_name(lvl);
      line += ": ";
    }
  }
  // One message, one journal entry: embedded newlines would split it.
  for (char c : message) line += c == '\n' ? ' ' : c;
  line += '\n';
  cli::write_stderr(line);
}

void write_priority(int priority, std::string_view message) {
  write(static_cast<Level>(std::clamp(priority, 3, 7)), message);
}

}  // namespace sculpt::log
