// sculpt-bench accuracy: work-precision data. Error against run time (and
// against a deterministic cost: passes over the springs) for six integrators,
// float and double, over a sweep of tick lengths and substeps, on problems
// with known answers (lab/problems.hpp).
//
//   sculpt-bench accuracy [--problem oscillator,chain,mesh] [--integrator verlet,...|all]
//                         [--precision float|double|both] [--dt LIST] [--substeps LIST]
//                         [--impl daemon|lab] [--json] [--out DIR] [--quiet]
#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "commands.hpp"
#include "common.hpp"
#include "lab/accuracy.hpp"
#include "sim/world.hpp"

namespace sculpt::bench {
namespace {

const std::vector<std::string> kColumns = {"problem",   "integrator",   "precision",    "impl",     "dt",
                                           "substeps",  "h",            "seconds",      "spring_passes",
                                           "error_max", "error_rms",    "energy_error", "diverged", "blowups",
                                           "ticks"};

nlohmann::json row(const lab::Problem& p, const lab::CaseResult& r) {
  nlohmann::json j;
  j["problem"] = p.name;
  j["integrator"] = std::string(lab::name(r.spec.method));
  j["precision"] = r.spec.use_double ? "double" : "float";
  j["impl"] = r.spec.impl == lab::Impl::daemon ? "daemon" : "lab";
  j["dt"] = r.spec.dt;
  j["substeps"] = r.spec.substeps;
  j["h"] = r.spec.dt / r.spec.substeps;
  j["seconds"] = r.seconds;
  j["spring_passes"] = r.spring_passes;
  j["error_max"] = r.diverged ? nlohmann::json() : nlohmann::json(r.error_max);
  j["error_rms"] = r.diverged ? nlohmann::json() : nlohmann::json(r.error_rms);
  j["energy_error"] = r.energy_error < 0 || r.diverged ? nlohmann::json() : nlohmann::json(r.energy_error);
  j["diverged"] = r.diverged;
  j["blowups"] = r.blowups;
  j["ticks"] = r.ticks;
  return j;
}

// Default substeps: 1, except XPBD, whose substeps are its accuracy knob.
std::vector<int> substeps_for(lab::Method m, const std::vector<double>& given) {
  if (!given.empty()) {
    std::vector<int> out;
    for (double s : given) {
      if (s != std::floor(s) || s < 1 || s > 4096) throw std::invalid_argument("--substeps: whole numbers in [1, 4096]");
      out.push_back(int(s));
    }
    return out;
  }
  if (m == lab::Method::xpbd) return {1, 4, 16};
  return {1};
}

void plot_problem(const Report& report, const std::string& problem) {
  // One series per integrator, precision and substeps, as measured.
  std::vector<std::string> series;
  std::set<std::string> seen;
  for (const nlohmann::json& r : report.rows()) {
    if (r["problem"] != problem) continue;
    const std::string key = r["integrator"].get<std::string>() + "|" + r["precision"].get<std::string>() + "|" +
                            std::to_string(r["substeps"].get<int>());
    if (seen.insert(key).second) series.push_back(key);
  }
  if (series.empty()) return;
  auto plots = [&](const std::string& xcol) {
    std::ostringstream s;
    for (std::size_t i = 0; i < series.size(); ++i) {
      const auto k = split(series[i], '|');
      const std::string title = k[0] + " " + k[1] + (k[2] == "1" ? "" : " x" + k[2]);
      s << (i ? ", \\\n  " : "plot ") << "'accuracy.csv' using (strcol(1) eq '" << problem << "' && strcol(2) eq '"
        << k[0] << "' && strcol(3) eq '" << k[1] << "' && $6 == " << k[2] << " ? " << xcol
        << " : NaN):10 with linespoints lw 1.5 pt " << (i % 13) + 1 << " dt " << (k[1] == "float" ? 1 : 2)
        << " title '" << title << "'";
    }
    return s.str() + "\n";
  };
  std::ostringstream g;
  g << "set multiplot layout 1,2 title 'accuracy: " << problem
    << " (max position error over the run; dashed = double)'\nset logscale xy\nset format x '%g'\nset format y '%.0e'\n"
    << "set ylabel 'max position error (m)'\nset xlabel 'passes over the springs (deterministic cost)'\nunset key\n"
    << plots("$9") << "set xlabel 'run time (s)'\nset key outside right\n" << plots("$8") << "unset multiplot\n";
  report.plot("accuracy_" + problem + ".png", g.str());
}

}  // namespace

int accuracy(const AccuracyOptions& o) {
  std::vector<lab::Method> methods;
  if (o.integrators == "all") {
    methods.assign(std::begin(lab::kAllMethods), std::end(lab::kAllMethods));
  } else {
    for (const std::string& s : split(o.integrators, ',')) {
      const auto m = lab::parse_method(s);
      if (!m)
        throw std::invalid_argument("--integrator " + s +
                                    ": expected verlet, velocity_verlet, symplectic_euler, explicit_euler, "
                                    "implicit_euler, xpbd or all");
      methods.push_back(*m);
    }
  }
  std::vector<bool> precisions;
  if (o.precision == "float" || o.precision == "both") precisions.push_back(false);
  if (o.precision == "double" || o.precision == "both") precisions.push_back(true);
  if (precisions.empty()) throw std::invalid_argument("--precision " + o.precision + ": expected float, double or both");
  if (o.impl != "daemon" && o.impl != "lab") throw std::invalid_argument("--impl " + o.impl + ": expected daemon or lab");
  const std::vector<double> dt_list = o.dts.empty() ? std::vector<double>{} : parse_list("--dt", o.dts);
  const std::vector<double> sub_list = o.substeps.empty() ? std::vector<double>{} : parse_list("--substeps", o.substeps);

  std::vector<lab::Problem> problems;
  for (const std::string& name : split(o.problems, ',')) problems.push_back(lab::make_problem(name));

  Report report(o.out, "accuracy", kColumns);
  std::size_t total = 0, done = 0;
  for (const lab::Problem& p : problems)
    for (lab::Method m : methods)
      total += precisions.size() * (dt_list.empty() ? p.dts.size() : dt_list.size()) * substeps_for(m, sub_list).size();
  for (const lab::Problem& p : problems) {
    const std::vector<double> dts = dt_list.empty() ? p.dts : dt_list;
    lab::ReferenceCache refs(p, *std::min_element(dts.begin(), dts.end()));
    for (lab::Method m : methods)
      for (bool dbl : precisions)
        for (int sub : substeps_for(m, sub_list)) {
          std::vector<lab::CaseResult> group;
          for (double dt : dts) {
            lab::CaseSpec spec;
            spec.method = m;
            spec.impl = lab::daemon_has(m) && o.impl == "daemon" ? lab::Impl::daemon : lab::Impl::lab;
            spec.use_double = dbl;
            spec.dt = dt;
            spec.substeps = sub;
            if (!p.exact) report.progress("reference for dt " + std::to_string(dt));
            const lab::Reference* ref = refs.get(dt);
            const lab::CaseResult r = lab::run_case(p, spec, ref);
            report.add(row(p, r));
            group.push_back(r);
            ++done;
          }
          std::ostringstream s;
          s << "[" << done << "/" << total << "] " << p.name << " " << lab::name(m) << " " << (dbl ? "double" : "float")
            << " x" << sub << ": measured order " << lab::convergence_order(group);
          report.progress(s.str());
        }
  }
  if (report.writing()) {
    report.write_csv();
    for (const lab::Problem& p : problems) plot_problem(report, p.name);
  }
  return 0;
}

}  // namespace sculpt::bench
