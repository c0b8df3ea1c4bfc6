// sculpt-bench stability: the largest stable step of each shipped mesh and
// material, measured by bisection (a kicked mesh in daemon/sim's World, and
// the lab's guard-free copy of position Verlet), against the Gershgorin bound
// the daemon uses (sim/stability) and a power-iteration λmax; with and
// without damping. Then, for every shipped scene, whether the automatic
// substep choice keeps its safety margin against the measured critical step.
//
//   sculpt-bench stability [--mesh LIST] [--material rubber,clay,jelly] [--damping on,off]
//                          [--scene LIST|none] [--ticks N] [--tolerance REL] [--json] [--out DIR] [--quiet]
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <sstream>
#include <stdexcept>

#include "commands.hpp"
#include "common.hpp"
#include "lab/stability.hpp"
#include "scene/scene.hpp"
#include "sim/stability.hpp"
#include "sim/world.hpp"

#ifndef SCULPT_SOURCE_DIR
#define SCULPT_SOURCE_DIR "."
#endif

namespace sculpt::bench {
namespace {

const std::vector<std::string> kMeshColumns = {
    "mesh", "material", "damping", "vertices", "springs", "max_degree", "dt_bound_gershgorin", "dt_power_iteration",
    "dt_critical_measured", "dt_critical_lab", "lambda_gershgorin", "lambda_power", "measured_over_bound",
    "measured_over_power", "probes"};
const std::vector<std::string> kSceneColumns = {"scene", "mesh", "material", "vertices", "rate_hz", "substeps",
                                                "auto_substeps", "substep_dt", "dt_bound_gershgorin",
                                                "dt_critical_measured", "margin", "required_margin", "margin_ok",
                                                "kicked_blowups"};

std::string source_path(const std::string& rel) { return std::string(SCULPT_SOURCE_DIR) + "/" + rel; }

std::vector<std::string> shipped_meshes() {
  std::vector<std::string> out;
  for (const auto& e : std::filesystem::directory_iterator(source_path("tests/data/meshes"))) {
    const std::string ext = e.path().extension().string();
    if (ext == ".bin") continue;  // a glTF's buffer, not a mesh
    out.push_back(e.path().string());
  }
  std::sort(out.begin(), out.end());
  // The built-in shapes at the default scene's sizes.
  for (const char* b : {"builtin:icosphere:3", "builtin:torus:0.07:0.028:40:20", "builtin:box:12"}) out.push_back(b);
  return out;
}

std::vector<std::string> shipped_scenes() {
  std::vector<std::string> out;
  for (const auto& e : std::filesystem::directory_iterator(source_path("tests/data/scenes")))
    if (e.path().extension() == ".toml") out.push_back(e.path().string());
  std::sort(out.begin(), out.end());
  out.push_back("builtin:default");
  return out;
}

std::string short_name(const std::string& spec) {
  return spec.rfind("builtin:", 0) == 0 ? spec : std::filesystem::path(spec).filename().string();
}

int max_degree(const sim::TriangleMesh& mesh) {
  std::vector<int> deg(mesh.positions.size());
  for (const sim::Edge& e : sim::unique_edges(mesh.triangles))
    if (e.a != e.b) ++deg[e.a], ++deg[e.b];
  return deg.empty() ? 0 : *std::max_element(deg.begin(), deg.end());
}

// The daemon's bisection: a kicked mesh in World<double>, one substep of dt.
double measure_daemon(const sim::TriangleMesh& mesh, const sim::Material& mat, double guess, int ticks, double tol,
                      int* probes) {
  const lab::Bisection b = lab::bisect_critical_dt(
      [&](double dt) { return lab::verlet_stable_daemon(mesh, mat, {}, dt, ticks); }, guess, tol);
  if (probes) *probes += b.probes;
  return b.dt;
}

void mesh_rows(const StabilityOptions& o, Report& report) {
  const auto presets = scene::material_presets();
  const std::vector<std::string> specs = o.meshes == "shipped" ? shipped_meshes() : split(o.meshes, ',');
  std::vector<bool> damping;
  for (const std::string& d : split(o.damping, ',')) {
    if (d != "on" && d != "off") throw std::invalid_argument("--damping " + o.damping + ": expected on, off or on,off");
    damping.push_back(d == "on");
  }
  std::size_t done = 0;
  const std::size_t total = specs.size() * split(o.materials, ',').size() * damping.size();
  for (const std::string& spec : specs) {
    const sim::TriangleMesh mesh = load_mesh_spec(spec);
    for (const std::string& mname : split(o.materials, ',')) {
      const auto it = presets.find(mname);
      if (it == presets.end()) throw std::invalid_argument("--material " + mname + ": expected rubber, clay or jelly");
      for (bool damped : damping) {
        sim::Material mat = it->second;
        mat.plastic = false;  // clay's yield would move the rest shape under the kick: stability of the springs only
        if (!damped) mat.damping = mat.anchor_damping = 0.0;
        const sim::StabilityBound bound = sim::stability_bound(mesh, mat);
        const lab::Model model = lab::Model::from_mesh(mesh, mat);
        const lab::PowerIteration pi = lab::power_iteration(model);
        const double dt_power = lab::verlet_dt_limit(pi.lambda_max, damped ? pi.mu : 0.0);
        int probes = 0;
        const double measured = measure_daemon(mesh, mat, bound.dt_critical, o.ticks, o.tolerance, &probes);
        const lab::Bisection lab_b = lab::bisect_critical_dt(
            [&](double dt) { return lab::verlet_stable_lab(model, dt, o.ticks); }, bound.dt_critical, o.tolerance);
        nlohmann::json r;
        r["mesh"] = short_name(spec);
        r["material"] = mname;
        r["damping"] = damped;
        r["vertices"] = mesh.positions.size();
        r["springs"] = model.springs.size();
        r["max_degree"] = max_degree(mesh);
        r["dt_bound_gershgorin"] = bound.dt_critical;
        r["lambda_gershgorin"] = bound.lambda_max_bound;
        r["lambda_power"] = pi.lambda_max;
        r["power_converged"] = pi.converged;
        r["dt_power_iteration"] = dt_power;
        r["dt_critical_measured"] = measured;
        r["dt_critical_lab"] = lab_b.dt;
        r["measured_over_bound"] = measured / bound.dt_critical;
        r["measured_over_power"] = measured / dt_power;
        r["probes"] = probes + lab_b.probes;
        report.add(r);
        report.progress("[" + std::to_string(++done) + "/" + std::to_string(total) + "] " + short_name(spec) + " " +
                        mname + (damped ? " damped" : " undamped"));
      }
    }
  }
}

void scene_rows(const StabilityOptions& o, Report& report) {
  const std::vector<std::string> files = o.scenes == "shipped" ? shipped_scenes() : split(o.scenes, ',');
  for (const std::string& file : files) {
    const scene::Scene sc = scene::load_scene(file);
    sim::World<float> world(sc.settings, 1);
    for (const scene::SceneMesh& m : sc.meshes) world.add_body(m.loaded.mesh, sc.material_of(m));
    // The scene as the daemon runs it (automatic substeps), every vertex kicked: no blow-up allowed.
    for (std::uint32_t b = 0; b < world.body_count(); ++b)
      for (std::uint32_t i = 0; i < world.body(b).n; ++i) {
        const sim::Vec3d p = world.position(b, i);
        world.set_state(b, i, p, {1e-3 * std::sin(i * 12.9898), 1e-3 * std::sin(i * 78.233), 1e-3 * std::sin(i * 37.719)});
      }
    for (int n = 0; n < o.ticks; ++n) world.step({});
    std::vector<std::uint64_t> blowups;
    for (std::uint32_t b = 0; b < world.body_count(); ++b) blowups.push_back(world.body(b).blowups);
    for (std::uint32_t b = 0; b < sc.meshes.size(); ++b) {
      const scene::SceneMesh& m = sc.meshes[b];
      sim::Material mat = sc.material_of(m);
      mat.plastic = false;
      const int sub = world.substeps(b);
      const double substep_dt = 1.0 / sc.settings.rate_hz / sub;
      const sim::StabilityBound bound = sim::stability_bound(m.loaded.mesh, mat);
      int probes = 0;
      // A coarser bisection than per mesh: the question is only whether the margin holds.
      const double measured =
          measure_daemon(m.loaded.mesh, mat, bound.dt_critical, o.ticks, std::max(o.tolerance, 1e-2), &probes);
      nlohmann::json r;
      r["scene"] = short_name(file);
      r["mesh"] = m.name;
      r["material"] = m.material;
      r["damping"] = mat.damping != 0.0 || mat.anchor_damping != 0.0;  // as the scene's material has it
      r["vertices"] = m.loaded.mesh.positions.size();
      r["rate_hz"] = sc.settings.rate_hz;
      r["substeps"] = sub;
      r["auto_substeps"] = sc.settings.substeps == 0;
      r["substep_dt"] = substep_dt;
      r["dt_bound_gershgorin"] = bound.dt_critical;
      r["dt_critical_measured"] = measured;
      r["margin"] = measured / substep_dt;
      r["required_margin"] = 1.0 / sc.settings.substep_safety;
      r["margin_ok"] = measured / substep_dt >= 1.0 / sc.settings.substep_safety;
      r["kicked_blowups"] = blowups[b];
      report.add(r);
      report.progress("scene " + short_name(file) + " " + m.name + ": margin " + std::to_string(measured / substep_dt));
    }
  }
}

}  // namespace

int stability(const StabilityOptions& o) {
  if (o.ticks < 100) throw std::invalid_argument("--ticks must be >= 100");
  if (!(o.tolerance > 0 && o.tolerance < 0.5)) throw std::invalid_argument("--tolerance must be in (0, 0.5)");
  Report meshes(o.out, "stability", kMeshColumns);
  Report scenes(o.out, "stability_scenes", kSceneColumns);
  if (o.meshes != "none") mesh_rows(o, meshes);
  if (o.scenes != "none") scene_rows(o, scenes);
  if (meshes.writing() && !meshes.rows().empty()) {
    meshes.write_csv();
    meshes.plot("stability.png",
                "set title 'largest stable step of position Verlet, per mesh, material and damping'\n"
                "set ylabel 'dt (ms)'\nset logscale y\nset xtics rotate by 60 right font ',7'\nset bmargin 14\n"
                "set style data linespoints\n"
                "plot 'stability.csv' using ($0):($9*1e3):xtic(sprintf('%s %s %s', strcol(1), strcol(2), "
                "strcol(3) eq 'true' ? 'damped' : 'undamped')) pt 7 title 'measured (World bisection)', \\\n"
                "  '' using ($0):($8*1e3) pt 6 title 'power iteration 2/sqrt(lambda)', \\\n"
                "  '' using ($0):($7*1e3) pt 2 title 'Gershgorin bound (daemon)'\n");
  }
  if (scenes.writing() && !scenes.rows().empty()) {
    scenes.write_csv();
    scenes.plot("stability_scenes.png",
                "set title 'measured critical step / the substep the daemon runs (shipped scenes)'\n"
                "set ylabel 'margin'\nset logscale y\nset xtics rotate by 45 right font ',8'\nset bmargin 10\n"
                "set style fill solid 0.6\nset boxwidth 0.6\n"
                "plot 'stability_scenes.csv' using ($0):11:xtic(sprintf('%s %s', strcol(1), strcol(2))) with boxes "
                "title 'margin', '' using ($0):12 with lines lw 2 title 'required (1/substep_safety)'\n");
  }
  return 0;
}

}  // namespace sculpt::bench
