// What the four programs (sculptd, sculptctl, sculpt-view, sculpt-bench) share
// on the command line, so that they speak with one voice:
//   - messages on stderr read "PROGRAM: error: MESSAGE" / "PROGRAM: warning: MESSAGE";
//   - an unknown option or command is named as such, with the valid ones listed;
//   - --help shows short value names (N, X, TEXT, {a,b}) and puts an option's
//     range into its description instead of CLI11's type text;
//   - exit statuses: 0 for --help/--version, 2 for a usage error.
#pragma once

#include <optional>
#include <string>
#include <string_view>

// Declared, not included: CLI11 costs seconds of compile time in every file
// that includes it, and most callers only print messages.
namespace CLI {
class App;
class ParseError;
}  // namespace CLI

namespace sculpt::cli {

inline constexpr int kExitUsage = 2;

// Names the program in every message; call once, first thing in main.
void set_program(std::string_view name);
const std::string& program();

// "PROGRAM: error: MESSAGE", "PROGRAM: warning: MESSAGE" and (progress)
// "PROGRAM: MESSAGE" on stderr, each one write.
void error(std::string_view message);
void warning(std::string_view message);
void note(std::string_view message);

// `text` (newline included) on stderr in as few write(2) calls as it takes,
// retrying on EINTR: a line from one thread never interleaves with another's.
void write_stderr(std::string_view text);

// The help layout above, for `app` and every subcommand added to it later.
void apply_conventions(CLI::App& app);

// Parses; nullopt when the program should go on, else the status to exit
// with after --help/--version (printed) or a usage error (reported as above).
// A command-line app with subcommands should use require_subcommand(0, 1):
// "no command given" is reported here, with the list of commands.
std::optional<int> parse(CLI::App& app, int argc, char** argv);

// The message for a usage error from `app`'s parse (for tests and callers
// that parse by themselves).
std::string usage_message(const CLI::App& app, const CLI::ParseError& e);

}  // namespace sculpt::cli
