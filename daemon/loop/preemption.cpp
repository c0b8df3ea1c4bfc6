#include "loop/preemption.hpp"

#include <sys/utsname.h>

#include <fstream>
#include <sstream>

namespace sculpt::loop {

namespace {

bool has_word(std::string_view text, std::string_view word) {
  for (std::size_t at = text.find(word); at != std::string_view::npos; at = text.find(word, at + 1)) {
    const bool starts = at == 0 || text[at - 1] == ' ';
    const std::size_t end = at + word.size();
    const bool ends = end == text.size() || text[end] == ' ' || text[end] == '\n';
    if (starts && ends) return true;
  }
  return false;
}

// "none voluntary (full) lazy" → "full".
std::string bracketed(std::string_view s) {
  const std::size_t open = s.find('(');
  const std::size_t close = s.find(')', open);
  if (open == std::string_view::npos || close == std::string_view::npos) return "";
  return std::string(s.substr(open + 1, close - open - 1));
}

// "... preempt=full ..." → "full".
std::string boot_param(std::string_view cmdline) {
  for (std::size_t at = cmdline.find("preempt="); at != std::string_view::npos; at = cmdline.find("preempt=", at + 1)) {
    if (at != 0 && cmdline[at - 1] != ' ') continue;  // not e.g. "xpreempt="
    const std::size_t from = at + 8;
    std::size_t end = cmdline.find_first_of(" \n", from);
    if (end == std::string_view::npos) end = cmdline.size();
    return std::string(cmdline.substr(from, end - from));
  }
  return "";
}

std::string read_all(const char* path) {
  std::ifstream f(path);
  std::stringstream s;
  s << f.rdbuf();
  return f ? s.str() : std::string();
}

}  // namespace

std::string preemption_model(std::string_view version, std::string_view debugfs, std::string_view cmdline) {
  if (has_word(version, "PREEMPT_RT")) return "rt";
  if (has_word(version, "PREEMPT_DYNAMIC")) {
    if (std::string m = bracketed(debugfs); !m.empty()) return m;
    return boot_param(cmdline);  // "" when the boot did not choose: the build's default, unknown here
  }
  if (has_word(version, "PREEMPT")) return "full";
  return "none";  // a build without preemption: none or voluntary, both wait the same way for RT wake-ups
}

std::optional<std::string> preemption_warning(std::string_view model) {
  if (model == "rt" || model == "full" || model == "lazy") return std::nullopt;
  const std::string what = model.empty() ? std::string("cannot be read (a dynamic kernel; mount debugfs to tell)")
                                         : "is \"" + std::string(model) + "\"";
  return "--realtime: the kernel's preemption model " + what +
         ": a woken SCHED_FIFO thread waits until the task on its CPU leaves the kernel, which made most "
         "overruns measured here (0.5-2.3 ms late wake-ups); boot with preempt=full (or write full to "
         "/sys/kernel/debug/sched/preempt)";
}

std::string current_preemption_model() {
  utsname u{};
  const std::string version = uname(&u) == 0 ? std::string(u.version) : std::string();
  return preemption_model(version, read_all("/sys/kernel/debug/sched/preempt"), read_all("/proc/cmdline"));
}

}  // namespace sculpt::loop
