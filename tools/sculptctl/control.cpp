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

void load(const LoadArgs& args) {
  if (args.scene.empty()) fail(kExitUsage, "load: the scene path is empty");
  std::string path = args.scene;
  if (path.rfind("builtin:", 0) != 0) path = std::filesystem::absolute(path).lexically_normal().string();
  with_daemon(args.daemon, [&](client::Connection& c, kj::WaitScope& ws) {
    auto req = c.session().loadSceneRequest();
    req.setPath(path);
    report(args.daemon, "load", req.send().wait(ws));
  });
}

void control(const DaemonArgs& args, Control what) {
  with_daemon(args, [&](client::Connection& c, kj::WaitScope& ws) {
    switch (what) {
      case Control::reset: report(args, "reset", c.session().resetRequest().send().wait(ws)); break;
      case Control::pause: report(args, "pause", c.session().pauseRequest().send().wait(ws)); break;
      case Control::resume: report(args, "resume", c.session().resumeRequest().send().wait(ws)); break;
    }
  });
}

}  // namespace sculpt::ctl
