#include "simloop/preemption.hpp"

#include <sys/utsname.h>

#include <fstream>
#include <sstream>

namespace sculpt::simloop {

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

// The build's default model of a dynamic kernel: the one "CONFIG_PREEMPT..=y" of its config.
std::string config_default(std::string_view config) {
  auto set = [&](std::string_view key) {
    const std::string line = "CONFIG_PREEMPT" + std::string(key) + "=y";
    for (std::size_t at = config.find(line); at != std::string_view::npos; at = config.find(line, at + 1)) {
      const std::size_t end = at + line.size();
      if ((at == 0 || config[at - 1] == '\n') && (end == config.size() || config[end] == '\n')) return true;
    }
    return false;
  };
  if (set("_NONE")) return "none";
  if (set("_VOLUNTARY")) return "voluntary";
  if (set("_LAZY")) return "lazy";
  if (set("")) return "full";
  return "";
}

std::string read_all(const std::string& path) {
  std::ifstream f(path);
  std::stringstream s;
  s << f.rdbuf();
  return f ? s.str() : std::string();
}

}  // namespace

std::string preemption_model(std::string_view version, std::string_view debugfs, std::string_view cmdline,
                             std::string_view kernel_config) {
  if (has_word(version, "PREEMPT_RT")) return "rt";
  if (has_word(version, "PREEMPT_DYNAMIC")) {
    if (std::string m = bracketed(debugfs); !m.empty()) return m;
    if (std::string m = boot_param(cmdline); !m.empty()) return m;
    return config_default(kernel_config);  // "" without a config to read
  }
  if (has_word(version, "PREEMPT")) return "full";
  return "none";  // a build without preemption: none or voluntary, both wait the same way for RT wake-ups
}

std::optional<std::string> preemption_warning(std::string_view model) {
  if (model == "rt" || model == "full" || model == "lazy") return std::nullopt;
  const std::string what = model.empty() ? std::string("cannot be read (a dynamic kernel: its mode is in "
                                                     "/sys/kernel/debug/sched/preempt, readable by root)")
                                         : "is \"" + std::string(model) + "\"";
  return "--realtime: the kernel's preemption model " + what +
         ": a woken SCHED_FIFO thread waits until the task on its CPU leaves the kernel, which made most "
         "overruns measured here (0.5-2.3 ms late wake-ups); boot with preempt=full (or write full to "
         "/sys/kernel/debug/sched/preempt)";
}

std::string current_preemption_model() {
  utsname u{};
  const bool named = uname(&u) == 0;
  const std::string version = named ? std::string(u.version) : std::string();
  const std::string config = named ? read_all(std::string("/boot/config-") + u.release) : std::string();
  return preemption_model(version, read_all("/sys/kernel/debug/sched/preempt"), read_all("/proc/cmdline"), config);
}

}  // namespace sculpt::simloop
