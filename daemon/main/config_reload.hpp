// SIGHUP: the config file is read again on its own thread (the io loop
// never waits on a file), the command line's flags put back on top, and the
// result handed to the io thread to apply. A SIGHUP during a reload reads
// the file again once that one is done. A file that cannot be read or
// applied keeps the running configuration, with the error logged.
#pragma once

#include <filesystem>
#include <functional>
#include <string>

#include <kj/async.h>

#include "main/config.hpp"
#include "host/worker.hpp"

namespace sculpt::daemon {

// The line telling which of `next`'s changes wait for a restart, or "" when none does.
std::string restart_needed(const DaemonConfig& running, const DaemonConfig& next);

class ConfigReload {
 public:
  // Applies a config read again; throws (std::exception) to refuse it.
  using Apply = std::function<void(DaemonConfig next)>;

  // `path` "" : nothing to read, the defaults are reloaded. `tasks` and
  // `stopping` outlive the reloader.
  ConfigReload(std::filesystem::path path, bool optional, std::function<void(DaemonConfig&)> overrides,
               kj::TaskSet& tasks, const bool& stopping, Apply apply);

  void request();

 private:
  void apply(std::optional<DaemonConfig> read, const std::string& read_error);

  std::filesystem::path path_;
  bool optional_;
  std::function<void(DaemonConfig&)> overrides_;
  kj::TaskSet& tasks_;
  const bool& stopping_;
  Apply apply_;
  Worker reader_;
  bool again_ = false;  // a SIGHUP came during a reload
};

}  // namespace sculpt::daemon
