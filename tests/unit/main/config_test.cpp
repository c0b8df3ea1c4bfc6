// sculptd's config file and command line: every key read, bad values named
// with file:line and key, flags over the file.
#include <gtest/gtest.h>

#include <CLI/CLI.hpp>

#include "main/room_settings.hpp"
#include "main/cli.hpp"
#include "main/config.hpp"

namespace sculpt::daemon {
namespace {

std::string error_of(std::string_view text) {
  try {
    parse_config(text, "test.conf");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(Config, DefaultsWithoutAFile) {
  const DaemonConfig c = parse_config("", "empty.conf");
  EXPECT_EQ(c.scene, "builtin:default");
  EXPECT_EQ(c.socket, kDefaultSocketPath);
  EXPECT_FALSE(c.rate_hz.has_value());
  EXPECT_EQ(c.input.kind, InputSpec::Kind::automatic);
  EXPECT_EQ(c.input_clock, InputClock::arrival);
  EXPECT_FALSE(c.realtime);
  EXPECT_FALSE(c.wake_early_us.has_value());  // the daemon picks by realtime
  EXPECT_EQ(c.log_level, log::Level::info);
  EXPECT_TRUE(c.haptics.enabled);
}

TEST(Config, MissingDefaultFileIsFineAMissingNamedOneIsNot) {
  EXPECT_NO_THROW(load_config("/nonexistent/sculptd.conf", true));
  EXPECT_THROW(load_config("/nonexistent/sculptd.conf", false), ConfigError);
}

TEST(Config, EveryKeyIsRead) {
  const DaemonConfig c = parse_config(R"(
[daemon]
scene = "s.toml"
socket = "/tmp/x.sock"
rate_hz = 500
input = "replay:recording.jsonl"
input_clock = "device"
input_delay_ms = 20
duration = 3.5
realtime = true
realtime_priority = 70
wake_early_us = 150
log_level = "debug"
stats_json = "/tmp/stats.json"
hash_out = "/tmp/hash"
watchdog_fraction = 0.25

[tools]
margin = 0.2
size_step = 1.5
min_scale = 0.5
max_scale = 2.0

[haptics]
enabled = false
poll_interval_ms = 8
usb_interval_ms = 12
bluetooth_interval_ms = 30
other_interval_ms = 40
stall_after_ms = 20
effect_length_ms = 30000
rearm_every_ms = 4000
gain = 1000
constant = false
rumble_on_onset = false
full_scale_newton = 3.0
min_level = 0.2
force_exponent = 0.7
level_gain = 0.9
level_limit = 0.6
contact_strong_ratio = 0.1
rumble_full_scale_impulse = 0.5
rumble_min_impulse = 0.01
rumble_weak_ratio = 0.25
rumble_length_ms = 80
level_step = 100
direction_step = 300
triggers = false
trigger_strength = 0.5
trigger_start = 40

[[haptics.device]]
vendor = 0x054c
product = 0x0ce6
level_limit = 0.3

[[haptics.device]]
name = "Xbox"
level_gain = 0.5

[input]
dead_zone = 0.1

[[device]]
name = "pad"
)", "full.conf");
  EXPECT_EQ(c.scene, "s.toml");
  EXPECT_EQ(c.socket, "/tmp/x.sock");
  EXPECT_EQ(c.rate_hz.value_or(0), 500.0);
  EXPECT_EQ(c.input.kind, InputSpec::Kind::replay);
  EXPECT_EQ(c.input.replay, "recording.jsonl");
  EXPECT_EQ(c.input_clock, InputClock::device);
  EXPECT_EQ(c.input_delay_ms, 20.0);
  EXPECT_EQ(c.duration_s, 3.5);
  EXPECT_TRUE(c.realtime);
  EXPECT_EQ(c.realtime_priority, 70);
  EXPECT_EQ(c.wake_early_us.value_or(-1), 150.0);
  EXPECT_EQ(c.log_level, log::Level::debug);
  EXPECT_EQ(c.stats_json, "/tmp/stats.json");
  EXPECT_EQ(c.hash_out, "/tmp/hash");
  EXPECT_EQ(c.watchdog_fraction, 0.25);
  EXPECT_EQ(c.tool_margin, 0.2);
  EXPECT_EQ(c.size_step, 1.5);
  EXPECT_EQ(c.min_scale, 0.5);
  EXPECT_EQ(c.max_scale, 2.0);
  EXPECT_FALSE(c.haptics.enabled);
  EXPECT_EQ(c.haptics.poll_interval.count(), 8);
  EXPECT_EQ(c.haptics.pacing.usb.count(), 12);
  EXPECT_EQ(c.haptics.pacing.bluetooth.count(), 30);
  EXPECT_EQ(c.haptics.pacing.other.count(), 40);
  EXPECT_EQ(c.haptics.stall_after.count(), 20);
  EXPECT_EQ(c.haptics.effect_length.count(), 30000);
  EXPECT_EQ(c.haptics.rearm_every.count(), 4000);
  EXPECT_EQ(c.haptics.gain, 1000);
  EXPECT_FALSE(c.haptics.constant);
  EXPECT_FALSE(c.haptics.rumble_on_onset);
  EXPECT_EQ(c.haptics.force.full_scale_newton, 3.0);
  EXPECT_EQ(c.haptics.force.min_level, 0.2);
  EXPECT_EQ(c.haptics.force.exponent, 0.7);
  EXPECT_EQ(c.haptics.tuning, (haptics::DeviceTuning{0.9, 0.6}));
  EXPECT_EQ(c.haptics.rumble.contact_strong_ratio, 0.1);
  ASSERT_EQ(c.haptics.devices.size(), 2u);
  EXPECT_EQ(c.haptics.devices[0].match.vendor.value_or(0), 0x054c);
  EXPECT_EQ(c.haptics.devices[0].match.product.value_or(0), 0x0ce6);
  EXPECT_EQ(c.haptics.devices[0].tuning, (haptics::DeviceTuning{0.9, 0.3}));  // [haptics]'s gain, its own limit
  EXPECT_EQ(c.haptics.devices[1].match.name, "Xbox");
  EXPECT_EQ(c.haptics.devices[1].tuning, (haptics::DeviceTuning{0.5, 0.6}));
  EXPECT_EQ(c.haptics.rumble.full_scale_impulse, 0.5);
  EXPECT_EQ(c.haptics.rumble.min_impulse, 0.01);
  EXPECT_EQ(c.haptics.rumble.weak_ratio, 0.25);
  EXPECT_EQ(c.haptics.rumble.length_ms, 80);
  EXPECT_EQ(c.haptics.change.level_step, 100);
  EXPECT_FALSE(c.haptics.triggers.enabled);
  EXPECT_EQ(c.haptics.triggers.strength, 0.5);
  EXPECT_EQ(c.haptics.triggers.start, 40);
  EXPECT_EQ(c.haptics.change.direction_step, 300);
  // The input module's tables are handed on whole.
  EXPECT_TRUE(c.mapping_table.contains("input"));
  EXPECT_TRUE(c.mapping_table.contains("device"));
}

TEST(Config, ErrorsNameFileLineAndKey) {
  EXPECT_EQ(error_of("[daemon]\nrate_hz = \"fast\"\n"), "test.conf:2: daemon.rate_hz: must be a number");
  EXPECT_EQ(error_of("\n\n[daemon]\nrate_hz = 0\n"), "test.conf:4: daemon.rate_hz: must be within [1, 100000]");
  EXPECT_NE(error_of("[daemon]\nratehz = 5\n").find("test.conf:2: daemon.ratehz: unknown key"), std::string::npos);
  EXPECT_NE(error_of("[deamon]\n").find("test.conf:1: deamon: unknown key"), std::string::npos);
  EXPECT_NE(error_of("[daemon]\ninput = \"joystick\"\n").find("test.conf:2: daemon.input:"), std::string::npos);
  EXPECT_NE(error_of("[daemon]\ninput_clock = \"wall\"\n").find("daemon.input_clock"), std::string::npos);
  EXPECT_NE(error_of("[daemon]\nlog_level = \"loud\"\n").find("daemon.log_level"), std::string::npos);
  EXPECT_EQ(error_of("[daemon]\nwake_early_us = 900\n"), "test.conf:2: daemon.wake_early_us: must be within [0, 500]");
  EXPECT_NE(error_of("[haptics]\ngain = 70000\n").find("test.conf:2: haptics.gain: must be within"), std::string::npos);
  EXPECT_NE(error_of("[haptics]\nlevel_limit = 1.5\n").find("haptics.level_limit: must be within [0, 1]"),
            std::string::npos);
  EXPECT_NE(error_of("[[haptics.device]]\nlevel_gain = 0.5\n").find("needs at least one of vendor, product, name"),
            std::string::npos);
  EXPECT_NE(error_of("[haptics]\neffect_length_ms = 5000\nrearm_every_ms = 6000\n").find("haptics.rearm_every_ms"),
            std::string::npos);
  EXPECT_NE(error_of("[tools]\nsize_step = 1\n").find("tools.size_step"), std::string::npos);
  EXPECT_NE(error_of("daemon = 3\n").find("daemon: must be a table"), std::string::npos);
  EXPECT_NE(error_of("[daemon\n").find("test.conf:1:"), std::string::npos);  // TOML syntax
}

TEST(InputSpec, Parses) {
  EXPECT_EQ(parse_input_spec("auto", "x").kind, InputSpec::Kind::automatic);
  EXPECT_EQ(parse_input_spec("evdev", "x").kind, InputSpec::Kind::evdev);
  const InputSpec r = parse_input_spec("replay:/a/b.jsonl", "x");
  EXPECT_EQ(r.kind, InputSpec::Kind::replay);
  EXPECT_EQ(r.replay, "/a/b.jsonl");
  EXPECT_EQ(to_string(r), "replay:/a/b.jsonl");
  EXPECT_THROW(parse_input_spec("replay:", "x"), ConfigError);
  EXPECT_THROW(parse_input_spec("", "x"), ConfigError);
}

CliOptions parse_cli(std::vector<std::string> args) {
  CLI::App app;
  CliOptions o;
  add_options(app, o);
  std::vector<const char*> argv{"sculptd"};
  for (auto& a : args) argv.push_back(a.c_str());
  app.parse(static_cast<int>(argv.size()), const_cast<char**>(argv.data()));
  return o;
}

// The ConfigError applying `args` to `c` gives ("" for none).
std::string cli_error(std::vector<std::string> args, DaemonConfig& c) {
  try {
    parse_cli(std::move(args)).apply(c);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return {};
}

TEST(Cli, FlagsOverrideTheFile) {
  DaemonConfig c = parse_config("[daemon]\nrate_hz = 500\nscene = \"a.toml\"\nsocket = \"/x\"\n", "f.conf");
  const CliOptions o = parse_cli({"--rate", "250", "--input", "replay:r.jsonl", "--input-clock", "device",
                                  "--duration", "2", "--realtime", "--stats-json", "s.json", "--hash-out", "h",
                                  "--log-level", "warning", "--input-delay", "10"});
  o.apply(c);
  EXPECT_EQ(c.rate_hz.value_or(0), 250.0);
  EXPECT_EQ(c.scene, "a.toml");  // not given: the file's
  EXPECT_EQ(c.socket, "/x");
  EXPECT_EQ(c.input.kind, InputSpec::Kind::replay);
  EXPECT_EQ(c.input_clock, InputClock::device);
  EXPECT_EQ(c.input_delay_ms, 10.0);
  EXPECT_EQ(c.duration_s, 2.0);
  EXPECT_TRUE(c.realtime);
  EXPECT_EQ(c.stats_json, "s.json");
  EXPECT_EQ(c.hash_out, "h");
  EXPECT_EQ(c.log_level, log::Level::warning);
  EXPECT_FALSE(o.config_given);
}

// The installed service passes --realtime; a drop-in turns it off with
// --no-realtime, whatever the config file says, and neither flag leaves the
// file's value alone.
TEST(Cli, NoRealtimeWinsOverTheFile) {
  DaemonConfig c = parse_config("[daemon]\nrealtime = true\n", "f.conf");
  parse_cli({"--no-realtime"}).apply(c);
  EXPECT_FALSE(c.realtime);
  DaemonConfig kept = parse_config("[daemon]\nrealtime = true\n", "f.conf");
  parse_cli({}).apply(kept);
  EXPECT_TRUE(kept.realtime);
}

TEST(Cli, BadFlagValuesAreNamed) {
  DaemonConfig c;
  auto msg = [&c](std::vector<std::string> args) { return cli_error(std::move(args), c); };
  EXPECT_NE(msg({"--rate", "0"}).find("--rate"), std::string::npos);
  EXPECT_NE(msg({"--input", "mouse"}).find("--input"), std::string::npos);
  EXPECT_NE(msg({"--input-clock", "x"}).find("--input-clock"), std::string::npos);
  EXPECT_NE(msg({"--duration", "-1"}).find("--duration"), std::string::npos);
  EXPECT_NE(msg({"--log-level", "x"}).find("--log-level"), std::string::npos);
  EXPECT_THROW(parse_cli({"--rate", "fast"}), CLI::ParseError);
  EXPECT_TRUE(parse_cli({"--config", "/etc/x.conf"}).config_given);
}

TEST(Config, TheKeeperSection) {
  DaemonConfig c = parse_config(
      "[keeper]\nenabled = false\ndir = \"/var/tmp/s\"\nsnapshot_interval_s = 5\nmax_mb = 64\nhistory_mb = 32\n", "f.conf");
  EXPECT_FALSE(c.keeper.enabled);
  EXPECT_EQ(c.keeper.dir, "/var/tmp/s");
  EXPECT_EQ(c.keeper.snapshot_interval_s, 5.0);
  EXPECT_EQ(c.keeper.max_mb, 64.0);
  EXPECT_EQ(c.keeper.history_mb, 32.0);
  EXPECT_NE(error_of("[keeper]\nmax_mb = 1\n").find("test.conf:2: keeper.max_mb: must be within"), std::string::npos);
  EXPECT_NE(error_of("[keeper]\npath = \"x\"\n").find("keeper.path: unknown key"), std::string::npos);
  EXPECT_NE(error_of("[keeper]\nmax_mb = 64\n[store]\nmax_mb = 64\n").find("[store] and [keeper] both given"),
            std::string::npos);
}

// [store], the section's old name, is still read (with a warning).
TEST(Config, TheStore) {
  DaemonConfig c = parse_config(
      "[store]\nenabled = false\ndir = \"/var/tmp/s\"\nsnapshot_interval_s = 5\nmax_mb = 64\nhistory_mb = 32\n", "f.conf");
  EXPECT_FALSE(c.keeper.enabled);
  EXPECT_EQ(c.keeper.dir, "/var/tmp/s");
  EXPECT_EQ(c.keeper.snapshot_interval_s, 5.0);
  EXPECT_EQ(c.keeper.max_mb, 64.0);
  EXPECT_EQ(c.keeper.history_mb, 32.0);
  EXPECT_NE(error_of("[store]\nmax_mb = 1\n").find("test.conf:2: store.max_mb: must be within"), std::string::npos);
  EXPECT_NE(error_of("[store]\npath = \"x\"\n").find("store.path: unknown key"), std::string::npos);

  const KeeperSettings k = keeper_settings(c);
  EXPECT_EQ(k.dir, "/var/tmp/s");
  EXPECT_EQ(k.limits.max_bytes, std::uint64_t{64} << 20);
  EXPECT_EQ(k.history_budget, std::uint64_t{32} << 20);
  EXPECT_EQ(k.snapshot_every, std::chrono::milliseconds(5000));
}

TEST(Config, AReplayIsSavedOnlyIntoADirectoryGivenForIt) {
  DaemonConfig c;
  EXPECT_TRUE(store_wanted(c));
  c.input = parse_input_spec("replay:r.jsonl", "x");
  EXPECT_FALSE(store_wanted(c));
  parse_cli({"--state-dir", "/tmp/s"}).apply(c);
  EXPECT_TRUE(store_wanted(c));
  parse_cli({"--no-store"}).apply(c);
  EXPECT_FALSE(store_wanted(c));
}

TEST(Config, TheStateDirectoryFollowsTheRule) {
  ::setenv("STATE_DIRECTORY", "/var/lib/sculptd:/var/lib/other", 1);
  EXPECT_EQ(state_dir(KeeperConfig{}), "/var/lib/sculptd");
  ::unsetenv("STATE_DIRECTORY");
  ::setenv("XDG_STATE_HOME", "/home/u/.state", 1);
  EXPECT_EQ(state_dir(KeeperConfig{}), "/home/u/.state/sculptd");
  ::unsetenv("XDG_STATE_HOME");
  ::setenv("HOME", "/home/u", 1);
  EXPECT_EQ(state_dir(KeeperConfig{}), "/home/u/.local/state/sculptd");
  KeeperConfig given;
  given.dir = "/srv/s";
  EXPECT_EQ(state_dir(given), "/srv/s");
}

TEST(Cli, StoreFlagsThatCannotGoTogetherAreNamed) {
  DaemonConfig c;
  auto msg = [&c](std::vector<std::string> args) { return cli_error(std::move(args), c); };
  EXPECT_NE(msg({"--fresh", "--open", "a.sculpt"}).find("choose one"), std::string::npos);
  EXPECT_NE(msg({"--no-store", "--state-dir", "/x"}).find("--no-store"), std::string::npos);
  EXPECT_NE(msg({"--state-dir", ""}).find("--state-dir"), std::string::npos);
  DaemonConfig d;
  parse_cli({"--open", "a.sculpt"}).apply(d);
  EXPECT_EQ(d.keeper.open, "a.sculpt");
  EXPECT_TRUE(d.keeper.enabled);
  parse_cli({"--fresh"}).apply(d);
  EXPECT_TRUE(d.keeper.fresh);
}

}  // namespace
}  // namespace sculpt::daemon
