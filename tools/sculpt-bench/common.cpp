#include "common.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <limits>
#include <stdexcept>

#include "cli/conventions.hpp"
#include "scene/mesh_import.hpp"
#include "sim/shapes.hpp"

namespace sculpt::bench {

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : s) {
    if (c == sep) out.push_back(cur), cur.clear();
    else cur += c;
  }
  out.push_back(cur);
  return out;
}

sim::TriangleMesh load_mesh_spec(const std::string& spec) {
  if (spec.rfind("builtin:", 0) == 0) {
    const auto p = split(spec.substr(8), ':');
    try {
      if (p[0] == "icosphere" && p.size() <= 2) return sim::make_icosphere(0.1f, p.size() > 1 ? std::stoi(p[1]) : 7);
      if (p[0] == "torus" && (p.size() == 1 || p.size() == 5))
        return p.size() == 1 ? sim::make_torus(0.1f, 0.03f, 512, 200)
                             : sim::make_torus(std::stof(p[1]), std::stof(p[2]), std::stoi(p[3]), std::stoi(p[4]));
      if (p[0] == "box" && p.size() <= 2) return sim::make_box_grid({0.2f, 0.1f, 0.2f}, p.size() > 1 ? std::stoi(p[1]) : 128);
    } catch (const std::logic_error& e) {
      throw std::invalid_argument("--mesh " + spec + ": " + e.what());
    }
    throw std::invalid_argument("--mesh " + spec +
                                ": expected builtin:icosphere[:N], builtin:torus[:R:r:rings:sides] or builtin:box[:cells]");
  }
  return scene::load_mesh(spec).mesh;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n == 0 ? 0.0 : (n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]));
}

long peak_rss_bytes() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss * 1024L;
}

long anon_huge_page_bytes() {
  std::ifstream in("/proc/self/smaps_rollup");
  std::string key;
  long kib = 0;
  while (in >> key) {
    if (key == "AnonHugePages:" && in >> kib) return kib * 1024L;
    in.ignore(std::numeric_limits<std::streamsize>::max(), '\n');
  }
  return -1;
}

std::vector<double> parse_list(const std::string& option, const std::string& text) {
  std::vector<double> out;
  for (const std::string& item : split(text, ',')) {
    std::size_t used = 0;
    double v = 0;
    try {
      v = std::stod(item, &used);
    } catch (const std::logic_error&) {
      used = 0;
    }
    if (used != item.size() || item.empty() || !(v > 0))
      throw std::invalid_argument(option + " " + text + ": '" + item + "' is not a positive number");
    out.push_back(v);
  }
  return out;
}

void Report::add(const nlohmann::json& row) {
  rows_.push_back(row);
  if (o_.json) {
    std::cout << row.dump() << std::endl;
  } else {
    std::string line;
    for (const std::string& c : columns_)
      if (row.contains(c)) line += c + "=" + (row[c].is_string() ? row[c].get<std::string>() : row[c].dump()) + " ";
    std::cout << line << std::endl;
  }
}

void Report::progress(const std::string& what) const {
  if (!o_.quiet) cli::note(name_ + ": " + what);
}

std::filesystem::path Report::write_csv() const {
  if (o_.out.empty()) return {};
  std::filesystem::create_directories(o_.out);
  const std::filesystem::path file = std::filesystem::path(o_.out) / (name_ + ".csv");
  std::ofstream f(file);
  if (!f) throw std::runtime_error("cannot write " + file.string());
  for (std::size_t i = 0; i < columns_.size(); ++i) f << (i ? "," : "") << columns_[i];
  f << "\n";
  for (const nlohmann::json& row : rows_) {
    for (std::size_t i = 0; i < columns_.size(); ++i) {
      f << (i ? "," : "");
      if (!row.contains(columns_[i]) || row[columns_[i]].is_null()) f << "NaN";
      else if (row[columns_[i]].is_string()) f << row[columns_[i]].get<std::string>();
      else f << row[columns_[i]].dump();
    }
    f << "\n";
  }
  if (!f) throw std::runtime_error("cannot write " + file.string());
  return file;
}

void Report::plot(const std::string& png, const std::string& script) const {
  if (o_.out.empty()) return;
  const std::filesystem::path dir(o_.out), gp = dir / (std::filesystem::path(png).stem().string() + ".gp");
  {
    std::ofstream f(gp);
    f << "# Made by sculpt-bench " << name_ << " --out " << o_.out << "; run from that directory.\n"
      << "set terminal pngcairo size 1300,750 noenhanced font ',10'\nset output '" << png << "'\nset datafile separator ','\n"
      << "set key outside right\nset key autotitle columnhead\nset grid\n"
      << script;
    if (!f) throw std::runtime_error("cannot write " + gp.string());
  }
  const std::string cmd = "cd '" + dir.string() + "' && gnuplot '" + gp.filename().string() + "' 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) throw std::runtime_error("cannot run gnuplot");
  std::string out;
  char buf[256];
  while (fgets(buf, sizeof buf, p)) out += buf;
  if (pclose(p) != 0) throw std::runtime_error("gnuplot failed on " + gp.string() + ": " + out);
  progress("wrote " + (dir / png).string());
}

}  // namespace sculpt::bench
