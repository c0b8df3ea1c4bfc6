// sculpt-bench's commands: what each one takes and runs, one file each. The
// command line that fills these in is main.cpp, the only file that includes
// CLI11 (it costs seconds of compile time in every file that does).
#pragma once

#include <string>

#include "common.hpp"

namespace sculpt::bench {

// Steps per second of one mesh under a pressing tool, fast vs baseline (throughput.cpp).
struct ThroughputOptions {
  std::string mesh = "builtin:icosphere:7";
  std::string model = "spring";
  std::string precision = "float";
  std::string tool = "sphere";
  std::string impl = "both";
  std::string records = "auto";  // packed neighbour records: auto (by size) | on | off
  std::string ring = "on";       // bodies without records: the ring of records (on) or gathers from the arrays
  int steps = 100;
  int repeats = 5;
  bool json = false;
};
int throughput(const ThroughputOptions& o);

// Error against run time: six integrators, float and double (accuracy.cpp).
struct AccuracyOptions {
  std::string problems = "oscillator,chain,mesh";
  std::string integrators = "all";
  std::string precision = "both";
  std::string dts, substeps;
  std::string impl = "daemon";
  OutputOptions out;
};
int accuracy(const AccuracyOptions& o);

// Largest stable dt: measured, power iteration, Gershgorin (stability.cpp).
struct StabilityOptions {
  std::string meshes = "shipped";
  std::string materials = "rubber,clay,jelly";
  std::string damping = "on,off";
  std::string scenes = "shipped";
  int ticks = 1000;
  double tolerance = 2e-3;
  OutputOptions out;
};
int stability(const StabilityOptions& o);

// What sleeping saves: cost per tick and bytes streamed (skip.cpp).
struct SkipOptions {
  std::string scene = "builtin:default";
  int ticks = 1000;
  double fps = 60.0;
  std::string tolerances = "1e-5,3e-5,1e-4,3e-4,1e-3";
  std::string sleep_speeds = "1e-5,1e-4,1e-3";
  OutputOptions out;
};
int skip(const SkipOptions& o);

}  // namespace sculpt::bench
