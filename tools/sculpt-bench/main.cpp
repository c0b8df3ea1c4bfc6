// sculpt-bench: numbers about the simulation, printed, never asserted.
//
//   throughput  steps per second of one mesh under a pressing tool, fast vs baseline (throughput.cpp)
//   accuracy    error against run time, six integrators, float and double (accuracy.cpp)
//   stability   largest stable dt: measured, power iteration, Gershgorin; substep margins (stability.cpp)
//   skip        what sleeping saves: cost per tick and bytes streamed, idle and active (skip.cpp)
#include <CLI/CLI.hpp>
#include <exception>

#include "cli/conventions.hpp"
#include "common.hpp"

int main(int argc, char** argv) {
  using namespace sculpt::bench;
  sculpt::cli::set_program("sculpt-bench");
  CLI::App app{"sculpt-bench: simulation benchmarks (numbers, not pass/fail)"};
  sculpt::cli::apply_conventions(app);
  app.require_subcommand(0, 1);  // no command: cli::parse names the commands
  const Command commands[] = {add_throughput(app), add_accuracy(app), add_stability(app), add_skip(app)};
  if (const auto status = sculpt::cli::parse(app, argc, argv)) return *status;
  try {
    for (const Command& c : commands)
      if (c.app->parsed()) return c.run();
  } catch (const std::exception& e) {
    sculpt::cli::error(e.what());
    return 2;
  }
  return 0;
}
