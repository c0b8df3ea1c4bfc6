#include "cli/conventions.hpp"

#include <unistd.h>

#include <cerrno>
#include <memory>

#include <CLI/CLI.hpp>

#include "files/write_all.hpp"

namespace sculpt::cli {
namespace {

std::string& program_name() {
  static std::string name = "sculpt";
  return name;
}

void write_line(std::string line) {
  line += '\n';
  write_stderr(line);
}

// CLI11's type name is "TYPE" or "TYPE:validator text" ("INT:INT in [1 - 16]",
// "TEXT:{on,off}"). The help shows a short value name; choices stay visible.
std::string value_name(const CLI::Option* opt) {
  const std::string full = opt->get_type_name();
  const auto colon = full.find(':');
  const std::string base = full.substr(0, colon);
  const std::string rest = colon == std::string::npos ? "" : full.substr(colon + 1);
  if (!rest.empty() && rest.front() == '{') return rest;
  if (base == "INT" || base == "UINT") return "N";
  if (base == "FLOAT") return "X";
  return base;
}

// The validator text CLI11 appends to the type ("INT in [1 - 16]"), as
// "(1 - 16)" for the description; empty when there is none.
std::string range_note(const CLI::Option* opt) {
  const std::string full = opt->get_type_name();
  const auto open = full.find(" in [");
  if (open == std::string::npos) return "";
  const auto close = full.find(']', open);
  if (close == std::string::npos) return "";
  return "(" + full.substr(open + 5, close - open - 5) + ")";
}

class Formatter : public CLI::Formatter {
 public:
  Formatter() { column_width(32); }

  std::string make_option_opts(const CLI::Option* opt) const override {
    if (!opt->get_option_text().empty()) return " " + opt->get_option_text();
    if (opt->get_positional()) return opt->get_required() ? " (required)" : "";  // its name says what it is
    std::string out;
    if (opt->get_type_size() != 0) {
      const std::string name = value_name(opt);
      if (!name.empty()) out += " " + name;
      if (!opt->get_default_str().empty()) out += "=" + opt->get_default_str();
      if (opt->get_expected_max() == CLI::detail::expected_max_vector_size) out += " ...";
      if (opt->get_required()) out += " (required)";
    }
    return out;
  }

  std::string make_option_desc(const CLI::Option* opt) const override {
    const std::string note = range_note(opt);
    return note.empty() ? opt->get_description() : opt->get_description() + " " + note;
  }
};

std::string join_names(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

std::vector<std::string> command_names(const CLI::App& app) {
  std::vector<std::string> names;
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; }))
    if (!sub->get_name().empty()) names.push_back(sub->get_name());
  return names;
}

std::vector<std::string> option_names(const CLI::App& app) {
  std::vector<std::string> names;
  for (const CLI::Option* opt : app.get_options()) {
    if (opt->get_positional() || (opt->get_lnames().empty() && opt->get_snames().empty())) continue;
    names.push_back(opt->get_lnames().empty() ? "-" + opt->get_snames().front() : "--" + opt->get_lnames().front());
  }
  return names;
}

// The innermost app that took part in the parse: the program, or the
// (sub)command the user named.
const CLI::App* innermost(const CLI::App& app) {
  const CLI::App* at = &app;
  for (;;) {
    const auto parsed = at->get_subcommands();
    if (parsed.empty()) return at;
    at = parsed.back();
  }
}

std::string command_path(const CLI::App& app, const CLI::App* at) {
  std::string path;
  for (const CLI::App* a = at; a != nullptr && a != &app; a = a->get_parent()) path = a->get_name() + " " + path;
  return program() + (path.empty() ? "" : " " + path.substr(0, path.size() - 1));
}

}  // namespace

void write_stderr(std::string_view text) { (void)files::write_all(STDERR_FILENO, text); }

void set_program(std::string_view name) { program_name() = std::string(name); }
const std::string& program() { return program_name(); }

void error(std::string_view message) { write_line(program() + ": error: " + std::string(message)); }
void warning(std::string_view message) { write_line(program() + ": warning: " + std::string(message)); }
void note(std::string_view message) { write_line(program() + ": " + std::string(message)); }

void apply_conventions(CLI::App& app) {
  app.formatter(std::make_shared<Formatter>());
  // Subcommands added later inherit the formatter through option_defaults;
  // set it on those already there too.
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) sub->formatter(app.get_formatter());
}

std::string usage_message(const CLI::App& app, const CLI::ParseError& e) {
  const CLI::App* at = innermost(app);
  const std::string where = command_path(app, at);
  const std::string hint = " (see '" + where + " --help')";
  if (dynamic_cast<const CLI::ExtrasError*>(&e) != nullptr) {
    // The app that had arguments left over names them in remaining().
    const CLI::App* owner = at;
    for (const CLI::App* a = at; a != nullptr; a = a->get_parent())
      if (!a->remaining().empty()) { owner = a; break; }
    const auto left = owner->remaining();
    const std::string first = left.empty() ? std::string("?") : left.front();
    const std::string in = command_path(app, owner);
    if (!first.empty() && first.front() == '-') {
      const auto options = option_names(*owner);
      std::string msg = "unknown option '" + first + "' for " + in;
      if (!options.empty()) msg += "; its options are " + join_names(options);
      const auto commands = command_names(*owner);
      if (!commands.empty()) msg += "; its commands are " + join_names(commands);
      return msg;
    }
    const auto commands = command_names(*owner);
    if (!commands.empty() && owner->get_subcommands().empty())
      return "unknown command '" + first + "' for " + in + "; the commands are " + join_names(commands);
    return "unexpected argument '" + first + "' for " + in + hint;
  }
  return std::string(e.what()) + hint;
}

std::optional<int> parse(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    error(usage_message(app, e));
    return kExitUsage;
  }
  const auto commands = command_names(app);
  if (!commands.empty() && app.get_require_subcommand_min() == 0 && app.get_subcommands().empty()) {
    error("a command is required: one of " + join_names(commands) + " (see '" + program() + " --help')");
    return kExitUsage;
  }
  return std::nullopt;
}

}  // namespace sculpt::cli
