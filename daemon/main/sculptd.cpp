// sculptd: the haptic sculpting daemon. See docs/daemon.md.
#include <cstdio>
#include <exception>

#include "cli/conventions.hpp"
#include "main/cli.hpp"
#include "main/config.hpp"
#include "main/daemon.hpp"
#include "input/mapping.hpp"
#include "log/log.hpp"
#include "scene/scene.hpp"
#include "scene/scene_world.hpp"

int main(int argc, char** argv) {
  using namespace sculpt;
  cli::set_program("sculptd");
  daemon::CliOptions options;
  if (const auto status = daemon::parse_command_line(argc, argv, options)) return *status;
  daemon::RunOptions run;
  try {
    run.config = daemon::load_config(options.config, !options.config_given);
    options.apply(run.config);
    log::set_level(run.config.log_level);
    if (options.check) {
      // What starting would check (the scene read and its world built at the
      // rate it would run), then a short probe of its stability.
      input::parse_mapping(run.config.mapping_table, run.config.file.empty() ? "config" : run.config.file);
      const scene::Scene s = scene::load_scene(run.config.scene);
      const double rate = run.config.rate_hz.value_or(s.settings.rate_hz);
      auto world = scene::build_world(s, rate);
      for (const std::string& w : s.warnings) log::warning("scene {}: {}", s.file.string(), w);
      bool unstable = false;
      for (const std::string& w : scene::probe_stability(*world, s))
        if (!w.empty()) log::warning("scene {}: {}", s.file.string(), w), unstable = true;
      std::printf("config %s: ok\nscene %s: ok (%zu meshes, %zu tools, %g Hz)%s\n",
                  run.config.file.empty() ? "(defaults)" : run.config.file.c_str(), s.file.c_str(), s.meshes.size(),
                  s.tools.size(), rate, unstable ? ", but unstable: see the warnings" : "");
      return 0;
    }
  } catch (const std::exception& e) {
    log::err("{}", e.what());
    return 1;
  }
  run.config_path = options.config;
  run.config_optional = !options.config_given;
  run.overrides = [options](daemon::DaemonConfig& c) { options.apply(c); };
  return daemon::run(std::move(run));
}
