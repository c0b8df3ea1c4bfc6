// sculptd: the haptic sculpting daemon. See docs/daemon.md.
#include <cstdio>
#include <exception>

#include <CLI/CLI.hpp>

#include "main/cli.hpp"
#include "main/config.hpp"
#include "main/daemon.hpp"
#include "input/mapping.hpp"
#include "main/log.hpp"
#include "scene/scene.hpp"

#ifndef SCULPTD_VERSION
#define SCULPTD_VERSION "unknown"
#endif

int main(int argc, char** argv) {
  using namespace sculpt;
  CLI::App app{"sculptd " SCULPTD_VERSION ": joysticks push and pull elastic meshes, with force feedback"};
  app.set_version_flag("--version", SCULPTD_VERSION);
  daemon::CliOptions cli;
  daemon::add_options(app, cli);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  daemon::RunOptions run;
  try {
    run.config = daemon::load_config(cli.config, !cli.config_given);
    cli.apply(run.config);
    log::set_level(run.config.log_level);
    if (cli.check) {
      input::parse_mapping(run.config.mapping_table, run.config.file.empty() ? "config" : run.config.file);
      const scene::Scene s = scene::load_scene(run.config.scene);
      std::printf("config %s: ok\nscene %s: ok (%zu meshes, %zu tools)\n",
                  run.config.file.empty() ? "(defaults)" : run.config.file.c_str(), s.file.c_str(), s.meshes.size(),
                  s.tools.size());
      return 0;
    }
  } catch (const std::exception& e) {
    log::err("{}", e.what());
    return 1;
  }
  run.config_path = cli.config;
  run.config_optional = !cli.config_given;
  run.overrides = [cli](daemon::DaemonConfig& c) { cli.apply(c); };
  return daemon::run(std::move(run));
}
