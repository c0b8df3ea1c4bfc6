// sculpt-bench: numbers about the simulation, printed, never asserted. This
// file is its whole command line: every command, its options, and what it
// runs (commands.hpp).
//
//   throughput  steps per second of one mesh under a pressing tool, fast vs baseline (throughput.cpp)
//   accuracy    error against run time, six integrators, float and double (accuracy.cpp)
//   stability   largest stable dt: measured, power iteration, Gershgorin; substep margins (stability.cpp)
//   skip        what sleeping saves: cost per tick and bytes streamed, idle and active (skip.cpp)
#include <CLI/CLI.hpp>
#include <exception>
#include <functional>
#include <utility>
#include <vector>

#include "cli/conventions.hpp"
#include "commands.hpp"

namespace sculpt::bench {
namespace {

// --json, --out and --quiet of the measuring commands (common.hpp).
void add_output_options(CLI::App* app, OutputOptions& o) {
  app->add_flag("--json", o.json, "one JSON object per measured case, one per line");
  app->add_option("--out", o.out, "write CSV and PNG plots (gnuplot) into this directory, e.g. docs/benchmarks")
      ->type_name("DIR");
  app->add_flag("--quiet", o.quiet, "no progress on stderr");
}

struct Options {
  ThroughputOptions throughput;
  AccuracyOptions accuracy;
  StabilityOptions stability;
  SkipOptions skip;
};

// The command to run once parsed: registered with each command.
using Command = std::function<int()>;  // runs a subcommand, returns its exit status

std::vector<std::pair<CLI::App*, Command>> add_commands(CLI::App& app, Options& o) {
  std::vector<std::pair<CLI::App*, Command>> commands;
  ThroughputOptions& t = o.throughput;
  CLI::App* c = app.add_subcommand("throughput", "steps per second of one mesh under a pressing tool, fast vs baseline");
  c->add_option("--mesh", t.mesh, "builtin:icosphere[:N] | builtin:torus[:R:r:rings:sides] | builtin:box[:cells] | FILE")
      ->type_name("MESH");
  // Checked at parse time: the peak-memory child runs before throughput() looks at them.
  c->add_option("--model", t.model, "spring | linear")->check(CLI::IsMember({"spring", "linear"}));
  c->add_option("--precision", t.precision, "float | double")->check(CLI::IsMember({"float", "double"}));
  c->add_option("--tool", t.tool, "none | sphere")->check(CLI::IsMember({"none", "sphere"}));
  c->add_option("--steps", t.steps, "timed ticks per repeat")->check(CLI::Range(1, 1000000));
  c->add_option("--repeats", t.repeats, "repeats (medians are reported)")->check(CLI::Range(1, 10000));
  c->add_option("--impl", t.impl, "both | fast | baseline")->check(CLI::IsMember({"both", "fast", "baseline"}));
  c->add_option("--records", t.records, "packed neighbour records (AVX2 path): auto (by mesh size) | on | off")
      ->check(CLI::IsMember({"auto", "on", "off"}));
  c->add_option("--ring", t.ring,
                "float bodies without records: the ring of packed records (on) or gathers from the arrays (off)")
      ->check(CLI::IsMember({"on", "off"}));
  c->add_flag("--json", t.json, "one JSON line");
  commands.emplace_back(c, [&t] { return throughput(t); });

  AccuracyOptions& a = o.accuracy;
  c = app.add_subcommand("accuracy", "error against run time: six integrators, float and double, a dt sweep");
  c->add_option("--problem", a.problems, "comma-separated: oscillator, chain, mesh (default: all three)");
  c->add_option("--integrator", a.integrators,
                "comma-separated: verlet, velocity_verlet, symplectic_euler, explicit_euler, implicit_euler, xpbd, "
                "or all");
  c->add_option("--precision", a.precision, "float | double | both");
  c->add_option("--dt", a.dts, "tick lengths in seconds, comma-separated (default: the problem's sweep)");
  c->add_option("--substeps", a.substeps, "substeps per tick, comma-separated (default: 1; xpbd 1,4,16)");
  c->add_option("--impl", a.impl, "daemon (sim::World runs its three integrators) | lab (the lab's copies)");
  add_output_options(c, a.out);
  commands.emplace_back(c, [&a] { return accuracy(a); });

  StabilityOptions& s = o.stability;
  c = app.add_subcommand("stability", "largest stable dt: bisection vs Gershgorin vs power iteration");
  c->add_option("--mesh", s.meshes, "comma-separated mesh specs, 'shipped' (tests/data/meshes + builtins) or none");
  c->add_option("--material", s.materials, "comma-separated presets: rubber, clay, jelly");
  c->add_option("--damping", s.damping, "on, off or on,off");
  c->add_option("--scene", s.scenes,
                "comma-separated scene files, 'shipped' (tests/data/scenes + builtin:default) or none");
  c->add_option("--ticks", s.ticks, "ticks per stability probe");
  c->add_option("--tolerance", s.tolerance, "relative width of the bisection bracket");
  add_output_options(c, s.out);
  commands.emplace_back(c, [&s] { return stability(s); });

  SkipOptions& k = o.skip;
  c = app.add_subcommand("skip", "what sleeping saves: ms per tick and bytes streamed, active vs idle");
  c->add_option("--scene", k.scene, "scene file or builtin:default (a multi-mesh scene; the tool sculpts mesh 0)");
  c->add_option("--ticks", k.ticks, "ticks sculpting (and ticks idle)");
  c->add_option("--fps", k.fps, "viewer frames per second (deltas coalesce between frames)");
  c->add_option("--tolerance", k.tolerances, "delta tolerances to sweep, m, comma-separated");
  c->add_option("--sleep-speed", k.sleep_speeds, "sleep speeds to sweep, m/s, comma-separated");
  add_output_options(c, k.out);
  commands.emplace_back(c, [&k] { return skip(k); });
  return commands;
}

}  // namespace
}  // namespace sculpt::bench

int main(int argc, char** argv) {
  using namespace sculpt;
  cli::set_program("sculpt-bench");
  CLI::App app{"sculpt-bench: simulation benchmarks (numbers, not pass/fail)"};
  cli::apply_conventions(app);
  app.require_subcommand(0, 1);  // no command: cli::parse names the commands
  bench::Options options;
  const auto commands = bench::add_commands(app, options);
  if (const auto status = cli::parse(app, argc, argv)) return *status;
  try {
    for (const auto& [command, run] : commands)
      if (command->parsed()) return run();
  } catch (const std::exception& e) {
    cli::error(e.what());
    return 2;
  }
  return 0;
}
