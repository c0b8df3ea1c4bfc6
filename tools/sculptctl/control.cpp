// `sculptctl load SCENE | reset | pause | resume [--json]`: change what a
// running sculptd simulates. A scene path is made absolute here (the daemon's
// working directory is not the caller's). Failures print the daemon's error
// (naming the file and field) and exit 1; the daemon keeps its sculpt.
#include <filesystem>
#include <iostream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "daemon_link.hpp"

namespace sculpt::ctl {
namespace {

template <class Reply>
void report(const DaemonArgs& args, const char* what, Reply reply) {
  const auto r = reply.getResult();
  if (args.json)
    std::cout << nlohmann::json{{"command", what}, {"ok", r.getOk()}, {"error", r.getError().cStr()}}.dump() << "\n";
  if (!r.getOk()) {
    if (args.json) throw CommandFailed{kExitCommandFailed};
    fail(kExitCommandFailed, std::string(what) + ": " + r.getError().cStr());
  }
  if (!args.json) fmt::print("{}: ok\n", what);
}

}  // namespace

void add_control_commands(CLI::App& app) {
  {
    auto args = std::make_shared<DaemonArgs>();
    auto scene = std::make_shared<std::string>();
    auto* cmd = app.add_subcommand("load", "load another scene into the running daemon (keeps the sculpt on failure)");
    cmd->add_option("SCENE", *scene, "scene file (TOML) or builtin:default")->required();
    add_daemon_options(*cmd, *args);
    cmd->callback([args, scene] {
      std::string path = *scene;
      if (path.rfind("builtin:", 0) != 0) path = std::filesystem::absolute(path).lexically_normal().string();
      with_daemon(*args, [&](client::Connection& c, kj::WaitScope& ws) {
        auto req = c.session().loadSceneRequest();
        req.setPath(path);
        report(*args, "load", req.send().wait(ws));
      });
    });
  }
  struct Simple {
    const char* name;
    const char* help;
  };
  for (const Simple s : {Simple{"reset", "every mesh back to its shape as loaded"},
                         Simple{"pause", "stop simulating (the loop keeps its rate; viewers keep their stream)"},
                         Simple{"resume", "simulate again after pause"}}) {
    auto args = std::make_shared<DaemonArgs>();
    auto* cmd = app.add_subcommand(s.name, s.help);
    add_daemon_options(*cmd, *args);
    const std::string name = s.name;
    cmd->callback([args, name] {
      with_daemon(*args, [&](client::Connection& c, kj::WaitScope& ws) {
        if (name == "reset") report(*args, "reset", c.session().resetRequest().send().wait(ws));
        else if (name == "pause") report(*args, "pause", c.session().pauseRequest().send().wait(ws));
        else report(*args, "resume", c.session().resumeRequest().send().wait(ws));
      });
    });
  }
}

}  // namespace sculpt::ctl
