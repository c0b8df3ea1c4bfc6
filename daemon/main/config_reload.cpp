#include "main/config_reload.hpp"

#include <memory>
#include <optional>
#include <utility>

#include "log/log.hpp"

namespace sculpt::daemon {

std::string restart_needed(const DaemonConfig& running, const DaemonConfig& next) {
  if (next.scene != running.scene || next.rate_hz != running.rate_hz ||
      to_string(next.input) != to_string(running.input) || next.realtime != running.realtime ||
      next.realtime_priority != running.realtime_priority || next.wake_early_us != running.wake_early_us ||
      next.socket != running.socket || next.keeper.enabled != running.keeper.enabled ||
      next.keeper.dir != running.keeper.dir || next.keeper.snapshot_interval_s != running.keeper.snapshot_interval_s ||
      next.keeper.max_mb != running.keeper.max_mb || next.keeper.history_mb != running.keeper.history_mb)
    return "SIGHUP: scene, rate, input, socket, realtime, realtime_priority, wake_early_us and [keeper] changes "
           "take effect at the next start";
  return {};
}

ConfigReload::ConfigReload(std::filesystem::path path, bool optional, std::function<void(DaemonConfig&)> overrides,
                           kj::TaskSet& tasks, const bool& stopping, Apply apply)
    : path_(std::move(path)),
      optional_(optional),
      overrides_(std::move(overrides)),
      tasks_(tasks),
      stopping_(stopping),
      apply_(std::move(apply)) {}

void ConfigReload::request() {
  if (reader_.busy()) {
    again_ = true;
    return;
  }
  struct Read {
    std::optional<DaemonConfig> config;
    std::string error;
  };
  auto read = std::make_shared<Read>();
  tasks_.add(reader_.run([read, path = path_, optional = optional_] {
    try {
      read->config.emplace(path.empty() ? DaemonConfig{} : load_config(path, optional));
    } catch (const std::exception& e) {
      read->error = e.what();
    }
  }).then([this, read] {
    if (!stopping_) apply(std::move(read->config), read->error);
    if (std::exchange(again_, false) && !stopping_) request();
  }));
}

void ConfigReload::apply(std::optional<DaemonConfig> read, const std::string& read_error) {
  const std::string what = path_.empty() ? std::string("(no config file)") : path_.string();
  try {
    if (!read) throw std::runtime_error(read_error);
    DaemonConfig next = std::move(*read);
    if (overrides_) overrides_(next);
    apply_(std::move(next));
    log::notice("SIGHUP: reloaded {}", what);
  } catch (const std::exception& e) {
    log::err("SIGHUP: {}; keeping the running configuration", e.what());
  }
}

}  // namespace sculpt::daemon
