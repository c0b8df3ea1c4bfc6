#include "scene/scene.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <utility>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "files/regular_file.hpp"
#include "sim/shapes.hpp"
#include "sim/stability.hpp"

namespace sculpt::scene {
namespace fs = std::filesystem;
namespace {

constexpr std::uintmax_t kMaxSceneBytes = 16u << 20;

unsigned line_of(const toml::node& n) { return n.source().begin.line; }

std::string type_name(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a number";
    case toml::node_type::boolean: return "a boolean";
    case toml::node_type::array: return "an array";
    case toml::node_type::table: return "a table";
    default: return "a date or time";
  }
}

std::size_t levenshtein_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] != b[j - 1] ? 1u : 0u)});
      diag = up;
    }
  }
  return row[b.size()];
}

// " (did you mean 'x'?)" for the closest candidate within a small (Levenshtein) distance.
template <class Range>
std::string did_you_mean(std::string_view word, const Range& candidates) {
  std::string best;
  std::size_t best_d = std::max<std::size_t>(2, word.size() / 3) + 1;
  for (const auto& c : candidates) {
    const std::size_t d = levenshtein_distance(word, c);
    if (d < best_d) {
      best_d = d;
      best = std::string(c);
    }
  }
  return best.empty() ? std::string() : fmt::format(" (did you mean '{}'?)", best);
}

// One TOML table of the scene with the keys it may hold. Every accessor names
// the file, the line and the key when the value is wrong.
class Table {
 public:
  Table(const fs::path& file, const toml::table& table, std::string where,
        std::vector<std::string_view> allowed)
      : file_(file), table_(table), where_(std::move(where)), allowed_(std::move(allowed)) {
    for (auto&& [key, node] : table_) {
      if (std::find(allowed_.begin(), allowed_.end(), key.str()) == allowed_.end()) {
        throw SceneError(file_, key.source().begin.line ? key.source().begin.line : line_of(node),
                         fmt::format("{}unknown key '{}'{}", prefix(), key.str(), hint(key.str())));
      }
    }
  }

  const fs::path& file() const { return file_; }
  const std::string& where() const { return where_; }
  unsigned line() const { return table_.source().begin.line; }
  const toml::node* get(std::string_view key) const { return table_.get(key); }
  bool has(std::string_view key) const { return get(key) != nullptr; }
  unsigned line(std::string_view key) const {
    const toml::node* n = get(key);
    return n && line_of(*n) ? line_of(*n) : line();
  }

  [[noreturn]] void fail(std::string_view key, const std::string& what) const {
    throw SceneError(file_, line(key), fmt::format("{}{}: {}", prefix(), key, what));
  }
  [[noreturn]] void fail_here(const std::string& what) const {
    throw SceneError(file_, line(), prefix() + what);
  }

  double number(std::string_view key, double fallback) const {
    const toml::node* n = get(key);
    if (!n) return fallback;
    double v;
    if (auto i = n->as_integer()) v = static_cast<double>(i->get());
    else if (auto f = n->as_floating_point()) v = f->get();
    else fail(key, "must be a number, not " + type_name(*n));
    if (!std::isfinite(v)) fail(key, "must be a finite number");
    return v;
  }

  long long integer(std::string_view key, long long fallback, long long lo, long long hi) const {
    const toml::node* n = get(key);
    if (!n) return fallback;
    auto i = n->as_integer();
    if (!i) fail(key, "must be an integer, not " + type_name(*n));
    if (i->get() < lo || i->get() > hi) fail(key, fmt::format("must be in [{}, {}], got {}", lo, hi, i->get()));
    return i->get();
  }

  bool boolean(std::string_view key, bool fallback) const {
    const toml::node* n = get(key);
    if (!n) return fallback;
    auto b = n->as_boolean();
    if (!b) fail(key, "must be true or false, not " + type_name(*n));
    return b->get();
  }

  std::string string(std::string_view key, std::string fallback) const {
    const toml::node* n = get(key);
    if (!n) return fallback;
    auto s = n->as_string();
    if (!s) fail(key, "must be a string, not " + type_name(*n));
    return s->get();
  }

  Vec3d vec3(std::string_view key, Vec3d fallback) const {
    const toml::node* n = get(key);
    if (!n) return fallback;
    auto a = n->as_array();
    if (!a || a->size() != 3) fail(key, "must be an array of 3 numbers, like [0.0, 0.1, 0.0]");
    Vec3d v{};
    for (std::size_t k = 0; k < 3; ++k) {
      const toml::node& e = *a->get(k);
      if (auto i = e.as_integer()) v[k] = static_cast<double>(i->get());
      else if (auto f = e.as_floating_point()) v[k] = f->get();
      else fail(key, "must be an array of 3 numbers, not of " + type_name(e) + "s");
      if (!std::isfinite(v[k])) fail(key, "must hold finite numbers");
    }
    return v;
  }

  template <class E>
  E choice(std::string_view key, E fallback, std::initializer_list<std::pair<std::string_view, E>> options) const {
    if (!has(key)) return fallback;
    const std::string s = string(key, {});
    std::vector<std::string_view> names;
    for (const auto& [name, value] : options) {
      if (name == s) return value;
      names.push_back(name);
    }
    std::string list;
    for (auto n : names) list += (list.empty() ? "" : ", ") + std::string(n);
    fail(key, fmt::format("'{}' is not one of {}{}", s, list, did_you_mean(s, names)));
  }

  double positive(std::string_view key, double fallback) const {
    const double v = number(key, fallback);
    if (!(v > 0.0)) fail(key, fmt::format("must be > 0, got {}", v));
    return v;
  }
  double non_negative(std::string_view key, double fallback) const {
    const double v = number(key, fallback);
    if (!(v >= 0.0)) fail(key, fmt::format("must be >= 0, got {}", v));
    return v;
  }

  // A sub-table (or nullptr when absent); any other type is an error.
  const toml::table* table(std::string_view key) const {
    const toml::node* n = get(key);
    if (!n) return nullptr;
    auto t = n->as_table();
    if (!t) fail(key, "must be a table, not " + type_name(*n));
    return t;
  }

  // sim::validate names the field in its message ("...: mass must be ..."):
  // point at that field's line when it is in this table.
  [[noreturn]] void fail_validation(const std::invalid_argument& e) const {
    std::string msg = e.what();
    const auto colon = msg.rfind(": ");
    const std::string rest = colon == std::string::npos ? msg : msg.substr(colon + 2);
    const std::string field = rest.substr(0, rest.find(' '));
    const unsigned at = has(field) ? line(field) : line();
    throw SceneError(file_, at, prefix() + rest);
  }

 private:
  // A close match, or the whole list when it is short enough to read.
  std::string hint(std::string_view key) const {
    std::string h = did_you_mean(key, allowed_);
    if (!h.empty() || allowed_.size() > 8) return h;
    std::string list;
    for (auto k : allowed_) list += (list.empty() ? "" : ", ") + std::string(k);
    return " (allowed: " + list + ")";
  }

  std::string prefix() const { return where_.empty() ? std::string() : where_ + " "; }

  const fs::path& file_;
  const toml::table& table_;
  std::string where_;
  std::vector<std::string_view> allowed_;
};

std::vector<std::string_view> builtin_shape_keys(const std::string& shape) {
  if (shape == "icosphere") return {"radius", "subdivisions"};
  if (shape == "torus") return {"major_radius", "minor_radius", "rings", "sides"};
  return {"size", "cells"};  // box
}

// Reads the shape's params (always, so a parse-only pass still checks them)
// and generates it when asked. Throws std::invalid_argument from sim/shapes.
sim::TriangleMesh make_builtin_shape(const std::string& shape, const Table& p, bool generate) {
  if (shape == "icosphere") {
    const auto radius = static_cast<float>(p.positive("radius", 0.08));
    const auto subdivisions = static_cast<int>(p.integer("subdivisions", 3, 0, 7));
    return generate ? sim::make_icosphere(radius, subdivisions) : sim::TriangleMesh{};
  }
  if (shape == "torus") {
    const auto major = static_cast<float>(p.positive("major_radius", 0.08));
    const auto minor = static_cast<float>(p.positive("minor_radius", 0.03));
    if (minor >= major) p.fail("minor_radius", fmt::format("must be smaller than major_radius ({})", major));
    const auto rings = static_cast<int>(p.integer("rings", 48, 3, 2048));
    const auto sides = static_cast<int>(p.integer("sides", 24, 3, 1024));
    return generate ? sim::make_torus(major, minor, rings, sides) : sim::TriangleMesh{};
  }
  const Vec3d size = p.vec3("size", {0.16, 0.06, 0.16});
  for (double c : size)
    if (!(c > 0.0)) p.fail("size", "every size must be > 0");
  const auto cells = static_cast<int>(p.integer("cells", 12, 1, 256));
  const std::array<float, 3> sf{static_cast<float>(size[0]), static_cast<float>(size[1]), static_cast<float>(size[2])};
  return generate ? sim::make_box_grid(sf, cells) : sim::TriangleMesh{};
}

sim::SimSettings parse_simulation(const Table& t) {
  sim::SimSettings s;
  s.rate_hz = t.positive("rate_hz", s.rate_hz);
  if (!(s.rate_hz >= kMinRateHz && s.rate_hz <= kMaxRateHz))
    t.fail("rate_hz", fmt::format("must be in [{}, {}] Hz, got {}", kMinRateHz, kMaxRateHz, s.rate_hz));
  if (const toml::node* n = t.get("substeps")) {
    if (auto str = n->as_string()) {
      if (str->get() != "auto") t.fail("substeps", fmt::format("must be \"auto\" or an integer >= 1, not '{}'", str->get()));
      s.substeps = 0;
    } else if (n->is_integer()) {
      s.substeps = static_cast<int>(t.integer("substeps", 0, 1, sim::kMaxSubsteps));
    } else {
      t.fail("substeps", "must be \"auto\" or an integer >= 1, not " + type_name(*n));
    }
  }
  s.substep_safety = t.positive("substep_safety", s.substep_safety);
  if (s.substep_safety > 1.0) t.fail("substep_safety", fmt::format("must be in (0, 1], got {}", s.substep_safety));
  s.integrator = t.choice("integrator", s.integrator,
                          {{"position_verlet", sim::Integrator::position_verlet},
                           {"velocity_verlet", sim::Integrator::velocity_verlet},
                           {"symplectic_euler", sim::Integrator::symplectic_euler}});
  s.gravity = t.vec3("gravity", s.gravity);
  s.sleep_speed = t.non_negative("sleep_speed", s.sleep_speed);
  s.sleep_ticks = static_cast<int>(t.integer("sleep_ticks", s.sleep_ticks, 1, 1'000'000));
  s.max_tool_speed = t.positive("max_tool_speed", s.max_tool_speed);
  try {
    sim::validate(s);
  } catch (const std::invalid_argument& e) {
    t.fail_validation(e);
  }
  return s;
}

sim::Material parse_material(const Table& t, const std::string& name,
                             const std::map<std::string, sim::Material>& presets) {
  // Defaults come from the preset of the same name, or the one named by `base`, or rubber.
  std::string base = presets.count(name) ? name : "rubber";
  if (t.has("base")) {
    base = t.string("base", base);
    if (!presets.count(base)) {
      std::vector<std::string> names;
      for (const auto& [n, m] : presets) names.push_back(n);
      t.fail("base", fmt::format("no preset '{}' (presets: rubber, clay, jelly){}", base, did_you_mean(base, names)));
    }
  }
  sim::Material m = presets.at(base);
  m.name = name;
  m.model = t.choice("model", m.model, {{"spring", sim::ForceModel::spring}, {"linear", sim::ForceModel::linear}});
  m.mass = t.positive("mass", m.mass);
  m.stiffness = t.non_negative("stiffness", m.stiffness);
  m.damping = t.non_negative("damping", m.damping);
  m.anchor = t.non_negative("anchor", m.anchor);
  m.anchor_damping = t.non_negative("anchor_damping", m.anchor_damping);
  m.grab_stiffness = t.non_negative("grab_stiffness", m.grab_stiffness);
  m.gravity = t.boolean("gravity", m.gravity);
  m.plastic = t.boolean("plastic", m.plastic);
  m.yield_strain = t.positive("yield_strain", m.yield_strain);
  try {
    sim::validate(m);
  } catch (const std::invalid_argument& e) {
    t.fail_validation(e);
  }
  return m;
}

// p' = R·(s ⊙ p) + t with R = Rz·Ry·Rx; a mirroring scale flips the winding
// back so that counter-clockwise still means outside.
void apply_transform(sim::TriangleMesh& mesh, const MeshTransform& tf) {
  const double d = std::numbers::pi / 180.0;
  const double cx = std::cos(tf.rotation_deg[0] * d), sx = std::sin(tf.rotation_deg[0] * d);
  const double cy = std::cos(tf.rotation_deg[1] * d), sy = std::sin(tf.rotation_deg[1] * d);
  const double cz = std::cos(tf.rotation_deg[2] * d), sz = std::sin(tf.rotation_deg[2] * d);
  const double r[3][3] = {
      {cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx},
      {sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx},
      {-sy, cy * sx, cy * cx},
  };
  for (sim::Vec3f& p : mesh.positions) {
    const double q[3] = {p[0] * tf.scale[0], p[1] * tf.scale[1], p[2] * tf.scale[2]};
    for (int i = 0; i < 3; ++i) {
      p[i] = static_cast<float>(r[i][0] * q[0] + r[i][1] * q[1] + r[i][2] * q[2] + tf.position[i]);
    }
  }
  if (tf.scale[0] * tf.scale[1] * tf.scale[2] < 0.0) {
    for (sim::Triangle& t : mesh.triangles) std::swap(t[1], t[2]);
  }
}

SceneMesh parse_mesh(const Table& t, const std::map<std::string, sim::Material>& materials,
                     const SceneOptions& options) {
  SceneMesh m;
  m.line = t.line();
  if (!t.has("file")) t.fail_here("needs a 'file' (a mesh file, or builtin:icosphere, builtin:torus, builtin:box)");
  m.source = t.string("file", {});
  if (m.source.empty()) t.fail("file", "must not be empty");
  const bool builtin = m.source.rfind("builtin:", 0) == 0;
  const std::string shape = builtin ? m.source.substr(8) : std::string();
  if (builtin) {
    const auto shapes = builtin_shapes();
    if (std::find(shapes.begin(), shapes.end(), shape) == shapes.end()) {
      t.fail("file", fmt::format("no built-in shape '{}' (there are icosphere, torus, box){}", shape,
                                 did_you_mean(shape, shapes)));
    }
  } else {
    m.path = fs::path(m.source).is_absolute() ? fs::path(m.source) : t.file().parent_path() / m.source;
    if (t.has("params")) t.fail("params", "only builtin: shapes take params");
  }
  m.name = t.string("name", builtin ? shape : fs::path(m.source).stem().string());
  if (m.name.empty()) t.fail("name", "must not be empty");

  m.material = t.string("material", m.material);
  if (!materials.count(m.material)) {
    std::vector<std::string> names;
    for (const auto& [n, mat] : materials) names.push_back(n);
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
    t.fail("material", fmt::format("no material '{}' (defined: {}){}", m.material, list, did_you_mean(m.material, names)));
  }
  m.transform.position = t.vec3("position", m.transform.position);
  m.transform.rotation_deg = t.vec3("rotation", m.transform.rotation_deg);
  if (const toml::node* s = t.get("scale")) {
    if (s->is_array()) {
      m.transform.scale = t.vec3("scale", m.transform.scale);
    } else {
      const double u = t.number("scale", 1.0);
      m.transform.scale = {u, u, u};
    }
    for (double c : m.transform.scale)
      if (c == 0.0) t.fail("scale", "must not be 0 (it would flatten the mesh)");
  }
  ImportOptions import = options.import;
  import.weld_tolerance = t.non_negative("weld_tolerance", import.weld_tolerance);
  if (import.weld_tolerance > 0.01) t.fail("weld_tolerance", fmt::format("must be <= 0.01 (a fraction of the mesh size), got {}", import.weld_tolerance));

  // Shape parameters are checked even when meshes are not loaded.
  std::optional<Table> params;
  if (builtin) {
    const toml::table* p = t.table("params");
    static const toml::table empty;
    params.emplace(t.file(), p ? *p : empty, t.where() + " params", builtin_shape_keys(shape));
  }
  sim::TriangleMesh generated;
  if (builtin) {
    try {
      generated = make_builtin_shape(shape, *params, options.load_meshes);
    } catch (const std::invalid_argument& e) {
      t.fail(t.has("params") ? "params" : "file", e.what());
    }
  }
  if (!options.load_meshes) return m;

  try {
    m.loaded = builtin ? clean_mesh(generated, m.source, import)
                       : load_mesh(options.locate ? options.locate(m.source) : m.path, import);
  } catch (const LoadError& e) {
    t.fail("file", e.what());
  }
  apply_transform(m.loaded.mesh, m.transform);
  measure(m.loaded.mesh, m.loaded.report);  // the bounding box is now in scene space
  return m;
}

SceneTool parse_tool(const Table& t, std::size_t index) {
  SceneTool tool;
  tool.line = t.line();
  tool.name = t.string("name", fmt::format("tool{}", index + 1));
  if (tool.name.empty()) t.fail("name", "must not be empty");
  tool.shape = t.choice("shape", tool.shape, {{"sphere", ToolShape::sphere}, {"capsule", ToolShape::capsule}});
  tool.radius = t.positive("radius", tool.radius);
  tool.half_length = t.non_negative("half_length", tool.half_length);
  if (const toml::node* d = t.get("device")) {
    if (d->is_string()) {
      tool.device_name = t.string("device", {});
      if (tool.device_name.empty()) t.fail("device", "a device name must not be empty");
      tool.device = -1;
    } else if (d->is_integer()) {
      tool.device = static_cast<int>(t.integer("device", 0, 0, 255));
    } else {
      t.fail("device", "must be an index (0 = first joystick) or a name, not " + type_name(*d));
    }
  }
  tool.stick = t.choice("stick", tool.stick, {{"left", Stick::left}, {"right", Stick::right}, {"main", Stick::main}});
  tool.position = t.vec3("position", tool.position);
  tool.speed = t.positive("speed", tool.speed);
  return tool;
}

// An array of tables ([[mesh]]) or nothing.
const toml::array* array_of_tables(const fs::path& file, const toml::table& root, std::string_view key) {
  const toml::node* n = root.get(key);
  if (!n) return nullptr;
  const toml::array* a = n->as_array();
  if (!a) {
    throw SceneError(file, line_of(*n), fmt::format("'{}' must be a list of tables: write [[{}]] before each one, not [{}]", key, key, key));
  }
  for (const toml::node& e : *a) {
    if (!e.is_table()) {
      throw SceneError(file, line_of(e), fmt::format("every '{}' entry must be a table ([[{}]]), not {}", key, key, type_name(e)));
    }
  }
  return a;
}

}  // namespace

std::vector<std::string> builtin_shapes() { return {"box", "icosphere", "torus"}; }

std::map<std::string, sim::Material> material_presets() {
  std::map<std::string, sim::Material> presets;
  sim::Material rubber;
  rubber.name = "rubber";
  presets["rubber"] = rubber;

  sim::Material clay = rubber;
  clay.name = "clay";
  clay.stiffness = 300.0;
  clay.damping = 0.3;
  clay.anchor = 4.0;
  clay.plastic = true;
  clay.yield_strain = 0.01;
  presets["clay"] = clay;

  sim::Material jelly = rubber;
  jelly.name = "jelly";
  jelly.stiffness = 60.0;
  jelly.damping = 0.02;
  jelly.anchor = 1.0;
  presets["jelly"] = jelly;
  return presets;
}

std::string_view to_string(ToolShape shape) { return shape == ToolShape::sphere ? "sphere" : "capsule"; }
std::string_view to_string(Stick stick) {
  switch (stick) {
    case Stick::left: return "left";
    case Stick::right: return "right";
    case Stick::main: return "main";
  }
  return "?";
}

Scene parse_scene(std::string_view text, const fs::path& file, const SceneOptions& options) {
  toml::table root;
  try {
    root = toml::parse(text, file.string());
  } catch (const toml::parse_error& e) {
    throw SceneError(file, e.source().begin.line, fmt::format("not valid TOML: {}", e.description()));
  }
  Scene scene;
  scene.file = file;
  const Table top(file, root, "", {"version", "simulation", "materials", "mesh", "tool"});
  if (top.has("version")) top.integer("version", 1, 1, 1);

  if (const toml::table* sim = top.table("simulation")) {
    scene.settings = parse_simulation(Table(file, *sim, "[simulation]",
                                            {"rate_hz", "substeps", "substep_safety", "integrator", "gravity",
                                             "sleep_speed", "sleep_ticks", "max_tool_speed"}));
  }

  const auto presets = material_presets();
  scene.materials = presets;
  if (const toml::table* mats = top.table("materials")) {
    for (auto&& [key, node] : *mats) {
      const std::string name(key.str());
      const toml::table* mt = node.as_table();
      if (!mt) {
        throw SceneError(file, line_of(node),
                         fmt::format("[materials] '{}' must be a table ([materials.{}]), not {}", name, name, type_name(node)));
      }
      if (name.empty()) throw SceneError(file, line_of(node), "[materials] a material needs a name");
      scene.materials[name] = parse_material(
          Table(file, *mt, fmt::format("[materials.{}]", name),
                {"base", "model", "mass", "stiffness", "damping", "anchor", "anchor_damping", "grab_stiffness",
                 "gravity", "plastic", "yield_strain"}),
          name, presets);
    }
  }

  std::set<std::string> names;
  if (const toml::array* meshes = array_of_tables(file, root, "mesh")) {
    for (std::size_t i = 0; i < meshes->size(); ++i) {
      const Table t(file, *meshes->get(i)->as_table(), fmt::format("[[mesh]] #{}", i + 1),
                    {"name", "file", "params", "material", "position", "rotation", "scale", "weld_tolerance"});
      SceneMesh m = parse_mesh(t, scene.materials, options);
      if (!names.insert(m.name).second) {
        if (t.has("name")) t.fail("name", fmt::format("'{}' is already used by another mesh", m.name));
        for (int k = 2;; ++k) {  // a defaulted name: number it
          if (names.insert(fmt::format("{}-{}", m.name, k)).second) {
            m.name = fmt::format("{}-{}", m.name, k);
            break;
          }
        }
      }
      scene.meshes.push_back(std::move(m));
    }
  }

  std::set<std::string> tool_names;
  if (const toml::array* tools = array_of_tables(file, root, "tool")) {
    for (std::size_t i = 0; i < tools->size(); ++i) {
      const Table t(file, *tools->get(i)->as_table(), fmt::format("[[tool]] #{}", i + 1),
                    {"name", "shape", "radius", "half_length", "device", "stick", "position", "speed"});
      if (i == sim::kMaxTools) t.fail_here(fmt::format("more than {} tools: at most {} can be driven", sim::kMaxTools, sim::kMaxTools));
      SceneTool tool = parse_tool(t, i);
      if (!tool_names.insert(tool.name).second) t.fail("name", fmt::format("'{}' is already used by another tool", tool.name));
      for (const SceneTool& other : scene.tools) {
        if (other.device == tool.device && other.device_name == tool.device_name && other.stick == tool.stick) {
          scene.warnings.push_back(fmt::format("{}:{}: tools '{}' and '{}' follow the same stick and will move together",
                                               file.string(), tool.line, other.name, tool.name));
        }
      }
      scene.tools.push_back(std::move(tool));
    }
  }

  if (scene.meshes.empty()) scene.warnings.push_back(file.string() + ": the scene has no meshes: nothing to sculpt");
  if (scene.tools.empty()) scene.warnings.push_back(file.string() + ": the scene has no tools: nothing can touch the meshes");
  return scene;
}

Scene load_scene(const fs::path& file, const SceneOptions& options) {
  if (file == "builtin:default") return default_scene(options);
  if (file.string().rfind("builtin:", 0) == 0) {
    throw SceneError(file, 0, "no such built-in scene (there is builtin:default; builtin: shapes go in a [[mesh]])");
  }
  std::string text;
  try {
    text = files::read_regular(file, kMaxSceneBytes);
  } catch (const files::FileError& e) {
    throw SceneError(file, 0, e.reason());
  }
  return parse_scene(text, file, options);
}

Scene default_scene(const SceneOptions& options) {
  return parse_scene(default_scene_text(), "builtin:default", options);
}

}  // namespace sculpt::scene
