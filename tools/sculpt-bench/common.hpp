// What the sculpt-bench subcommands share: mesh specs, medians, output (JSON
// lines, CSV, gnuplot PNGs) and progress on stderr.
#pragma once

#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "sim/triangle_mesh.hpp"

namespace sculpt::bench {

std::vector<std::string> split(const std::string& s, char sep);

// builtin:icosphere[:N] | builtin:torus[:R:r:rings:sides] | builtin:box[:cells] | FILE
sim::TriangleMesh load_mesh_spec(const std::string& spec);

double median(std::vector<double> v);
long peak_rss_bytes();
// This process's memory now in transparent huge pages (AnonHugePages of
// /proc/self/smaps_rollup), or -1 where the kernel does not say.
long anon_huge_page_bytes();

// Comma-separated numbers ("0.004,0.002"); names the option on bad input.
std::vector<double> parse_list(const std::string& option, const std::string& text);

// Output shared by the measuring commands: --json prints one object per case
// (else a readable line per case); every case also becomes a CSV row, and
// --out DIR writes <name>.csv plus the plots (gnuplot) when the command ends.
struct OutputOptions {
  bool json = false;
  std::string out;   // directory for CSV and PNG; empty = none
  bool quiet = false;  // no progress on stderr
};

class Report {
 public:
  Report(const OutputOptions& o, std::string name, std::vector<std::string> columns)
      : o_(o), name_(std::move(name)), columns_(std::move(columns)) {}
  void add(const nlohmann::json& row);  // prints it at once
  void progress(const std::string& what) const;
  const std::vector<nlohmann::json>& rows() const { return rows_; }
  // Writes DIR/<name>.csv (if --out), returns its path (empty without --out).
  std::filesystem::path write_csv() const;
  // Runs gnuplot on `script` (which reads the CSV named by `csv`) to make DIR/<png>.
  void plot(const std::string& png, const std::string& script) const;
  bool writing() const { return !o_.out.empty(); }
  std::filesystem::path dir() const { return o_.out; }

 private:
  const OutputOptions& o_;
  std::string name_;
  std::vector<std::string> columns_;
  std::vector<nlohmann::json> rows_;
};

}  // namespace sculpt::bench
