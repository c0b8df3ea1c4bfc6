// sculptd's log: one line per message on stderr. When stderr is the journal
// ($JOURNAL_STREAM names it) each line starts with its sd-daemon priority
// (<3> error ... <7> debug) so journald keeps the levels; anywhere else (a
// terminal, a pipe, a file) it reads as the other programs' messages do:
// "sculptd: warning: ...". Thread-safe: each line is a single write(). Never
// call it from the sim thread.
#pragma once

#include <string>
#include <string_view>

#include <fmt/format.h>

namespace sculpt::log {

enum class Level : int { err = 3, warning = 4, notice = 5, info = 6, debug = 7 };

// Messages above this level are dropped. Default: info.
void set_level(Level level);
Level level();
// "err"/"error", "warning", "notice", "info", "debug"; false when unknown.
bool parse_level(std::string_view name, Level& out);
std::string_view level_name(Level level);

// Forces the sd-daemon prefix (true) or the plain form (false); by default
// the prefix is used only when stderr is the journal stream.
void set_journal_prefix(bool on);

void write(Level level, std::string_view message);
// A syslog priority from another module's log sink (input, server),
// clamped to the levels above.
void write_priority(int priority, std::string_view message);

template <class... Args>
void err(fmt::format_string<Args...> f, Args&&... args) { write(Level::err, fmt::format(f, std::forward<Args>(args)...)); }
template <class... Args>
void warning(fmt::format_string<Args...> f, Args&&... args) { write(Level::warning, fmt::format(f, std::forward<Args>(args)...)); }
template <class... Args>
void notice(fmt::format_string<Args...> f, Args&&... args) { write(Level::notice, fmt::format(f, std::forward<Args>(args)...)); }
template <class... Args>
void info(fmt::format_string<Args...> f, Args&&... args) { write(Level::info, fmt::format(f, std::forward<Args>(args)...)); }
template <class... Args>
void debug(fmt::format_string<Args...> f, Args&&... args) {
  if (level() >= Level::debug) write(Level::debug, fmt::format(f, std::forward<Args>(args)...));
}

}  // namespace sculpt::log
