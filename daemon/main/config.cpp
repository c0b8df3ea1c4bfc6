#include "main/config.hpp"

#include <cmath>
#include <set>

#include <fmt/format.h>

#include "files/regular_file.hpp"

namespace sculpt::daemon {
namespace {

// A config file is a few lines; anything this big is something else.
constexpr std::uint64_t kMaxConfigBytes = std::uint64_t{1} << 20;

using Path = std::filesystem::path;

std::string where(const Path& file, const toml::node& node) {
  const auto& src = node.source();
  return fmt::format("{}:{}", file.string(), src.begin.line);
}

[[noreturn]] void fail(const Path& file, const toml::node& node, std::string_view key, std::string_view msg) {
  throw ConfigError(fmt::format("{}: {}: {}", where(file, node), key, msg));
}

void check_keys(const Path& file, const toml::table& table, std::string_view section,
                const std::set<std::string_view>& known) {
  for (const auto& [k, v] : table) {
    if (!known.count(k.str())) {
      std::string list;
      for (auto n : known) list += (list.empty() ? "" : ", ") + std::string(n);
      fail(file, v, fmt::format("{}{}{}", section, section.empty() ? "" : ".", k.str()),
           fmt::format("unknown key (known: {})", list));
    }
  }
}

// Typed readers: absent → leave `out` alone; wrong type or range → ConfigError.
struct Reader {
  const Path& file;
  const toml::table& table;
  std::string section;

  std::string name(std::string_view key) const { return section + "." + std::string(key); }

  bool get(std::string_view key, std::string& out) const {
    const toml::node* n = table.get(key);
    if (!n) return false;
    if (!n->is_string()) fail(file, *n, name(key), "must be a string");
    out = n->as_string()->get();
    return true;
  }
  bool get(std::string_view key, bool& out) const {
    const toml::node* n = table.get(key);
    if (!n) return false;
    if (!n->is_boolean()) fail(file, *n, name(key), "must be true or false");
    out = n->as_boolean()->get();
    return true;
  }
  bool get(std::string_view key, double& out, double lo, double hi) const {
    const toml::node* n = table.get(key);
    if (!n) return false;
    double v;
    if (n->is_integer()) v = static_cast<double>(n->as_integer()->get());
    else if (n->is_floating_point()) v = n->as_floating_point()->get();
    else fail(file, *n, name(key), "must be a number");
    if (!std::isfinite(v) || v < lo || v > hi) fail(file, *n, name(key), fmt::format("must be within [{}, {}]", lo, hi));
    out = v;
    return true;
  }
  bool get(std::string_view key, int& out, int lo, int hi) const {
    const toml::node* n = table.get(key);
    if (!n) return false;
    if (!n->is_integer()) fail(file, *n, name(key), "must be an integer");
    const auto v = n->as_integer()->get();
    if (v < lo || v > hi) fail(file, *n, name(key), fmt::format("must be within [{}, {}]", lo, hi));
    out = static_cast<int>(v);
    return true;
  }
  bool get_ms(std::string_view key, std::chrono::milliseconds& out, int lo, int hi) const {
    int v = static_cast<int>(out.count());
    if (!get(key, v, lo, hi)) return false;
    out = std::chrono::milliseconds(v);
    return true;
  }
};

const toml::table* sub_table(const Path& file, const toml::table& root, std::string_view key) {
  const toml::node* n = root.get(key);
  if (!n) return nullptr;
  if (!n->is_table()) fail(file, *n, key, "must be a table ([" + std::string(key) + "])");
  return n->as_table();
}

void read_daemon(const Path& file, const toml::table& t, DaemonConfig& c) {
  check_keys(file, t, "daemon",
             {"scene", "socket", "rate_hz", "input", "input_clock", "input_delay_ms", "duration", "realtime",
              "realtime_priority", "wake_early_us", "log_level", "stats_json", "hash_out", "watchdog_fraction"});
  const Reader r{file, t, "daemon"};
  r.get("scene", c.scene);
  r.get("socket", c.socket);
  double rate = 0;
  if (r.get("rate_hz", rate, simloop::kRateRange.lo, simloop::kRateRange.hi)) c.rate_hz = rate;
  std::string s;
  if (r.get("input", s)) {
    try {
      c.input = parse_input_spec(s, "daemon.input");
    } catch (const ConfigError& e) {
      fail(file, *t.get("input"), "daemon.input", e.what());
    }
  }
  if (r.get("input_clock", s)) {
    if (s == "arrival") c.input_clock = InputClock::arrival;
    else if (s == "device") c.input_clock = InputClock::device;
    else fail(file, *t.get("input_clock"), "daemon.input_clock", "must be \"arrival\" or \"device\"");
  }
  r.get("input_delay_ms", c.input_delay_ms, 0.0, 10000.0);
  r.get("duration", c.duration_s, 0.0, 1e9);
  r.get("realtime", c.realtime);
  r.get("realtime_priority", c.realtime_priority, 1, 99);
  double early = 0;
  if (r.get("wake_early_us", early, 0.0, 500.0)) c.wake_early_us = early;
  if (r.get("log_level", s) && !log::parse_level(s, c.log_level))
    fail(file, *t.get("log_level"), "daemon.log_level", "must be one of error, warning, notice, info, debug");
  r.get("stats_json", c.stats_json);
  r.get("hash_out", c.hash_out);
  r.get("watchdog_fraction", c.watchdog_fraction, 0.05, 0.9);
}

void read_tools(const Path& file, const toml::table& t, DaemonConfig& c) {
  check_keys(file, t, "tools", {"margin", "size_step", "min_scale", "max_scale"});
  const Reader r{file, t, "tools"};
  r.get("margin", c.tool_margin, simloop::kToolMarginRange.lo, simloop::kToolMarginRange.hi);
  r.get("size_step", c.size_step, simloop::kSizeStepRange.lo, simloop::kSizeStepRange.hi);
  r.get("min_scale", c.min_scale, simloop::kMinScaleRange.lo, simloop::kMinScaleRange.hi);
  r.get("max_scale", c.max_scale, simloop::kMaxScaleRange.lo, simloop::kMaxScaleRange.hi);
}

// `section`: "keeper", or its old name "store" (errors name the one written).
void read_keeper(const Path& file, const toml::table& t, const char* section, DaemonConfig& c) {
  check_keys(file, t, section, {"enabled", "dir", "snapshot_interval_s", "max_mb", "history_mb"});
  const Reader r{file, t, section};
  r.get("enabled", c.keeper.enabled);
  r.get("dir", c.keeper.dir);
  r.get("snapshot_interval_s", c.keeper.snapshot_interval_s, 1.0, 86400.0);
  r.get("max_mb", c.keeper.max_mb, 16.0, 1048576.0);
  r.get("history_mb", c.keeper.history_mb, 0.0, 1048576.0);
}

// One [[haptics.device]] entry: what it matches (at least one of vendor,
// product, name) and the gain and limit it gets instead of [haptics]'s.
haptics::DeviceOverride read_device_override(const Path& file, const toml::table& t, std::size_t index,
                                             const haptics::DeviceTuning& base) {
  const std::string section = fmt::format("haptics.device[{}]", index);
  check_keys(file, t, section, {"vendor", "product", "name", "level_gain", "level_limit"});
  const Reader r{file, t, section};
  haptics::DeviceOverride o;
  o.tuning = base;
  int id = 0;
  if (r.get("vendor", id, 0, 0xffff)) o.match.vendor = static_cast<std::uint16_t>(id);
  if (r.get("product", id, 0, 0xffff)) o.match.product = static_cast<std::uint16_t>(id);
  r.get("name", o.match.name);
  if (!o.match.vendor && !o.match.product && o.match.name.empty())
    fail(file, t, section, "needs at least one of vendor, product, name");
  r.get("level_gain", o.tuning.gain, 0.0, 1.0);
  r.get("level_limit", o.tuning.limit, 0.0, 1.0);
  return o;
}

void read_haptics(const Path& file, const toml::table& t, DaemonConfig& c) {
  check_keys(file, t, "haptics",
             {"enabled", "poll_interval_ms", "usb_interval_ms", "bluetooth_interval_ms", "other_interval_ms",
              "stall_after_ms", "effect_length_ms", "rearm_every_ms", "gain", "constant", "rumble_on_onset",
              "full_scale_newton", "min_level", "force_exponent", "level_gain", "level_limit",
              "rumble_full_scale_impulse", "rumble_min_impulse", "rumble_min_strength", "rumble_weak_ratio",
              "rumble_length_ms", "contact_strong_ratio", "level_step", "direction_step", "device", "triggers",
              "trigger_strength", "trigger_start"});
  const Reader r{file, t, "haptics"};
  auto& h = c.haptics;
  r.get("enabled", h.enabled);
  r.get_ms("poll_interval_ms", h.poll_interval, 1, 1000);
  r.get_ms("usb_interval_ms", h.pacing.usb, 0, 1000);
  r.get_ms("bluetooth_interval_ms", h.pacing.bluetooth, 0, 1000);
  r.get_ms("other_interval_ms", h.pacing.other, 0, 1000);
  r.get_ms("stall_after_ms", h.stall_after, 2, 1000);
  r.get_ms("effect_length_ms", h.effect_length, 1000, 60000);
  r.get_ms("rearm_every_ms", h.rearm_every, 100, 60000);
  if (h.rearm_every >= h.effect_length)
    fail(file, t, "haptics.rearm_every_ms", "must be shorter than effect_length_ms");
  int gain = h.gain;
  if (r.get("gain", gain, 0, 0xffff)) h.gain = static_cast<std::uint16_t>(gain);
  r.get("constant", h.constant);
  r.get("rumble_on_onset", h.rumble_on_onset);
  r.get("full_scale_newton", h.force.full_scale_newton, 1e-6, 1e6);
  r.get("min_level", h.force.min_level, 0.0, 1.0);
  r.get("force_exponent", h.force.exponent, 0.1, 4.0);
  r.get("level_gain", h.tuning.gain, 0.0, 1.0);
  r.get("level_limit", h.tuning.limit, 0.0, 1.0);
  r.get("rumble_full_scale_impulse", h.rumble.full_scale_impulse, 1e-9, 1e6);
  r.get("rumble_min_impulse", h.rumble.min_impulse, 0.0, 1e6);
  r.get("rumble_min_strength", h.rumble.min_strength, 0.0, 1.0);
  r.get("rumble_weak_ratio", h.rumble.weak_ratio, 0.0, 1.0);
  r.get("contact_strong_ratio", h.rumble.contact_strong_ratio, 0.0, 1.0);
  int len = h.rumble.length_ms;
  if (r.get("rumble_length_ms", len, 1, 1000)) h.rumble.length_ms = static_cast<std::uint16_t>(len);
  r.get("level_step", h.change.level_step, 0, 0x7fff);
  r.get("direction_step", h.change.direction_step, 0, 0xffff);
  h.devices.clear();
  if (const toml::node* n = t.get("device")) {
    const toml::array* list = n->as_array();
    if (!list) fail(file, *n, "haptics.device", "must be an array of tables ([[haptics.device]])");
    for (std::size_t i = 0; i < list->size(); ++i) {
      const toml::table* entry = (*list)[i].as_table();
      if (!entry) fail(file, (*list)[i], "haptics.device", "must be an array of tables ([[haptics.device]])");
      h.devices.push_back(read_device_override(file, *entry, i, h.tuning));
    }
  }
  r.get("triggers", h.triggers.enabled);
  r.get("trigger_strength", h.triggers.strength, 0.0, 1.0);
  int start = h.triggers.start;
  if (r.get("trigger_start", start, 0, 255)) h.triggers.start = static_cast<std::uint8_t>(start);
}

}  // namespace

InputSpec parse_input_spec(std::string_view text, std::string_view what) {
  InputSpec s;
  if (text == "auto") s.kind = InputSpec::Kind::automatic;
  else if (text == "evdev") s.kind = InputSpec::Kind::evdev;
  else if (text.substr(0, 7) == "replay:" && text.size() > 7) {
    s.kind = InputSpec::Kind::replay;
    s.replay = std::string(text.substr(7));
  } else {
    throw ConfigError(fmt::format("{}: \"{}\" is not an input; use auto, evdev or replay:FILE", what, text));
  }
  return s;
}

std::string to_string(const InputSpec& spec) {
  switch (spec.kind) {
    case InputSpec::Kind::automatic: return "auto";
    case InputSpec::Kind::evdev: return "evdev";
    case InputSpec::Kind::replay: return "replay:" + spec.replay.string();
  }
  return "?";
}

DaemonConfig parse_config(std::string_view text, const std::filesystem::path& file) {
  toml::table root;
  try {
    root = toml::parse(text, file.string());
  } catch (const toml::parse_error& e) {
    throw ConfigError(fmt::format("{}:{}: {}", file.string(), e.source().begin.line, e.description()));
  }
  DaemonConfig c;
  c.file = file;
  check_keys(file, root, "", {"daemon", "tools", "haptics", "keeper", "store", "input", "device"});
  if (const toml::table* t = sub_table(file, root, "daemon")) read_daemon(file, *t, c);
  if (const toml::table* t = sub_table(file, root, "tools")) read_tools(file, *t, c);
  if (const toml::table* t = sub_table(file, root, "haptics")) read_haptics(file, *t, c);
  const toml::table* keeper = sub_table(file, root, "keeper");
  const toml::table* store = sub_table(file, root, "store");
  if (keeper && store)
    throw ConfigError(fmt::format("{}: [store] and [keeper] both given: [store] is the old name of [keeper]; keep one",
                                  file.string()));
  if (keeper) read_keeper(file, *keeper, "keeper", c);
  if (store) {
    log::warning("{}: [store] is now called [keeper]: rename the section (it is read as [keeper])", file.string());
    read_keeper(file, *store, "store", c);
  }
  // The input module reads its own keys ([input], [[device]]) from the root.
  c.mapping_table = std::move(root);
  return c;
}

simloop::SimulationSettings simulation_settings(const DaemonConfig& config) {
  const bool replay = config.input.kind == InputSpec::Kind::replay;
  return simloop::SimulationSettings{.rate_hz = config.rate_hz,
                                  .tool_margin = config.tool_margin,
                                  .size_step = config.size_step,
                                  .min_scale = config.min_scale,
                                  .max_scale = config.max_scale,
                                  .ring_capacity = replay ? simloop::kReplayRingCapacity : simloop::kLiveRingCapacity};
}

DaemonConfig load_config(const std::filesystem::path& file, bool optional) {
  std::error_code ec;
  if (optional && !std::filesystem::exists(file, ec) && !std::filesystem::is_symlink(file, ec)) return DaemonConfig{};
  // The one special file a config may be: /dev/null, the usual "no config".
  if (file == "/dev/null") return parse_config("", file);
  try {
    return parse_config(files::read_regular(file, kMaxConfigBytes), file);
  } catch (const files::FileError& e) {
    throw ConfigError(fmt::format("{}: cannot read the config file: {}", file.string(), e.reason()));
  }
}

}  // namespace sculpt::daemon
