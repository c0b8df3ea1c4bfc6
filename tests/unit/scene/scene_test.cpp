#include "scene/scene.hpp"

#include <cmath>

#include <gtest/gtest.h>

#include "sim/shapes.hpp"
#include "test_data.hpp"

namespace sculpt::scene {
namespace {

using testing::data_dir;
using testing::error_of;
using testing::TempDir;

const SceneMesh& mesh_named(const Scene& s, const std::string& name) {
  for (const SceneMesh& m : s.meshes)
    if (m.name == name) return m;
  throw std::runtime_error("no mesh " + name);
}

TEST(SceneFile, EveryFieldIsRead) {
  const Scene s = load_scene(data_dir() / "scenes" / "full.toml");
  EXPECT_EQ(s.settings.rate_hz, 500.0);
  EXPECT_EQ(s.settings.substeps, 4);
  EXPECT_EQ(s.settings.substep_safety, 0.4);
  EXPECT_EQ(s.settings.integrator, sim::Integrator::velocity_verlet);
  EXPECT_EQ(s.settings.gravity, (std::array<double, 3>{0.0, 0.0, -9.81}));
  EXPECT_EQ(s.settings.sleep_speed, 2e-4);
  EXPECT_EQ(s.settings.sleep_ticks, 80);
  EXPECT_EQ(s.settings.max_tool_speed, 10.0);

  const sim::Material& putty = s.materials.at("putty");
  EXPECT_EQ(putty.name, "putty");
  EXPECT_EQ(putty.model, sim::ForceModel::linear);
  EXPECT_EQ(putty.mass, 0.02);
  EXPECT_EQ(putty.stiffness, 150.0);
  EXPECT_EQ(putty.damping, 0.1);
  EXPECT_EQ(putty.anchor, 3.0);
  EXPECT_EQ(putty.anchor_damping, 0.2);
  EXPECT_EQ(putty.grab_stiffness, 80.0);
  EXPECT_TRUE(putty.gravity);
  EXPECT_TRUE(putty.plastic);
  EXPECT_EQ(putty.yield_strain, 0.05);
  // Redefining a preset starts from that preset.
  EXPECT_EQ(s.materials.at("rubber").stiffness, 250.0);
  EXPECT_EQ(s.materials.at("rubber").mass, sim::Material{}.mass);

  ASSERT_EQ(s.meshes.size(), 4u);
  const SceneMesh& ball = mesh_named(s, "ball");
  EXPECT_EQ(ball.material, "putty");
  EXPECT_EQ(ball.path, data_dir() / "scenes" / "../meshes/icosphere_binary.stl");
  EXPECT_EQ(ball.transform.position, (Vec3d{0.5, 0.0, 0.0}));
  EXPECT_EQ(ball.transform.rotation_deg, (Vec3d{0.0, 90.0, 0.0}));
  EXPECT_EQ(ball.transform.scale, (Vec3d{2.0, 2.0, 2.0}));
  EXPECT_EQ(ball.loaded.report.vertices, 162u);
  // Radius 0.1 scaled by 2 around the origin, then moved to x = 0.5.
  EXPECT_NEAR(ball.loaded.report.bbox_min[0], 0.3f, 1e-5);
  EXPECT_NEAR(ball.loaded.report.bbox_max[0], 0.7f, 1e-5);
  EXPECT_NEAR(ball.loaded.report.bbox_max[1], 0.2f, 1e-5);

  const SceneMesh& ring = mesh_named(s, "ring");
  EXPECT_EQ(ring.source, "builtin:torus");
  EXPECT_EQ(ring.transform.scale, (Vec3d{0.5, 0.5, 0.5}));
  EXPECT_EQ(ring.loaded.report.vertices, 24u * 12u);
  EXPECT_NEAR(ring.loaded.report.bbox_max[0], 0.06f, 1e-5);  // (0.1 + 0.02) / 2
  EXPECT_EQ(mesh_named(s, "box").material, "rubber");        // name and material defaulted
  EXPECT_EQ(mesh_named(s, "icosphere").loaded.report.vertices, 42u);

  ASSERT_EQ(s.tools.size(), 2u);
  const SceneTool& finger = s.tools[0];
  EXPECT_EQ(finger.name, "finger");
  EXPECT_EQ(finger.shape, ToolShape::capsule);
  EXPECT_EQ(finger.radius, 0.01);
  EXPECT_EQ(finger.half_length, 0.05);
  EXPECT_EQ(finger.device_name, "Logitech Extreme 3D");
  EXPECT_EQ(finger.stick, Stick::main);
  EXPECT_EQ(finger.position, (Vec3d{0.0, 0.25, 0.1}));
  EXPECT_EQ(finger.speed, 0.8);
  EXPECT_EQ(s.tools[1].device, 1);
  EXPECT_EQ(s.tools[1].stick, Stick::right);
  EXPECT_TRUE(s.warnings.empty());
}

TEST(SceneFile, DefaultsOnly) {
  const Scene s = load_scene(data_dir() / "scenes" / "defaults.toml");
  const sim::SimSettings d;
  EXPECT_EQ(s.settings.rate_hz, d.rate_hz);
  EXPECT_EQ(s.settings.substeps, 0);
  EXPECT_EQ(s.settings.integrator, d.integrator);
  ASSERT_EQ(s.meshes.size(), 1u);
  EXPECT_EQ(s.meshes[0].name, "icosphere");
  EXPECT_EQ(s.meshes[0].material, "rubber");
  EXPECT_EQ(s.material_of(s.meshes[0]).stiffness, sim::Material{}.stiffness);
  EXPECT_EQ(s.meshes[0].loaded.report.boundary_edges, 0u);
  EXPECT_TRUE(s.tools.empty());
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("no tools"), std::string::npos);
}

TEST(SceneFile, EmptyFileIsAValidEmptyScene) {
  const Scene s = parse_scene("", "empty.toml");
  EXPECT_TRUE(s.meshes.empty());
  EXPECT_EQ(s.warnings.size(), 2u);
  EXPECT_EQ(s.materials.size(), material_presets().size());
}

TEST(DefaultScene, IsBuiltInAndClosed) {
  const Scene s = default_scene();
  EXPECT_EQ(s.file, "builtin:default");
  ASSERT_EQ(s.meshes.size(), 3u);
  EXPECT_EQ(s.material_of(mesh_named(s, "clay")).plastic, true);
  for (const SceneMesh& m : s.meshes) {
    EXPECT_TRUE(m.path.empty());
    EXPECT_EQ(m.loaded.report.boundary_edges, 0u) << m.name;
    EXPECT_EQ(m.loaded.report.components, 1u) << m.name;
    EXPECT_GT(sim::signed_volume(m.loaded.mesh), 0.0) << m.name;  // still outward after the rotation
  }
  ASSERT_EQ(s.tools.size(), 2u);
  EXPECT_EQ(s.tools[0].stick, Stick::left);
  EXPECT_EQ(s.tools[1].stick, Stick::right);
  EXPECT_EQ(s.tools[0].device, s.tools[1].device);
  EXPECT_TRUE(s.warnings.empty());
  // load_scene knows it by name too.
  EXPECT_EQ(load_scene("builtin:default").meshes.size(), 3u);
  EXPECT_EQ(error_of<SceneError>([] { load_scene("builtin:torus"); }),
            "builtin:torus: no such built-in scene (there is builtin:default; builtin: shapes go in a [[mesh]])");
}

TEST(SceneFile, MirroringScaleKeepsTrianglesOutward) {
  const Scene s = parse_scene(R"([[mesh]]
file = "builtin:icosphere"
scale = [-1.0, 1.0, 1.0]
)",
                              "mirror.toml");
  EXPECT_GT(sim::signed_volume(s.meshes[0].loaded.mesh), 0.0);
}

TEST(SceneFile, DefaultedNamesAreNumberedExplicitDuplicatesAreErrors) {
  const Scene s = parse_scene("[[mesh]]\nfile = \"builtin:box\"\n[[mesh]]\nfile = \"builtin:box\"\n", "two.toml");
  EXPECT_EQ(s.meshes[0].name, "box");
  EXPECT_EQ(s.meshes[1].name, "box-2");
  const std::string msg = error_of<SceneError>([] {
    parse_scene("[[mesh]]\nname = \"a\"\nfile = \"builtin:box\"\n[[mesh]]\nname = \"a\"\nfile = \"builtin:box\"\n",
                "dup.toml");
  });
  EXPECT_EQ(msg, "dup.toml:5: [[mesh]] #2 name: 'a' is already used by another mesh");
}

TEST(SceneFile, ParseOnlyChecksWithoutLoading) {
  SceneOptions parse_only;
  parse_only.load_meshes = false;
  const Scene s = load_scene(data_dir() / "scenes" / "full.toml", parse_only);
  ASSERT_EQ(s.meshes.size(), 4u);
  EXPECT_TRUE(s.meshes[0].loaded.mesh.positions.empty());
  // Bad shape parameters are still caught.
  EXPECT_NE(error_of<SceneError>([&] {
              parse_scene("[[mesh]]\nfile = \"builtin:icosphere\"\nparams = { subdivisions = 12 }\n", "p.toml", parse_only);
            }).find("p.toml:3: [[mesh]] #1 params subdivisions: must be in [0, 7], got 12"),
            std::string::npos);
}

// Each kind of mistake: one message, naming file:line and the key.
struct BadScene {
  const char* name;
  const char* text;
  const char* message;  // exact
};
class SceneErrors : public ::testing::TestWithParam<BadScene> {};

TEST_P(SceneErrors, NameFileLineAndKey) {
  EXPECT_EQ(error_of<SceneError>([] { parse_scene(GetParam().text, "s.toml"); }), GetParam().message);
}

INSTANTIATE_TEST_SUITE_P(
    Kinds, SceneErrors,
    ::testing::Values(
        BadScene{"typo", "[simulation]\nrate_hz = 1000\nsubstep = 2\n",
                 "s.toml:3: [simulation] unknown key 'substep' (did you mean 'substeps'?)"},
        BadScene{"top_level_typo", "[[meshes]]\nfile = \"a.obj\"\n",
                 "s.toml:1: unknown key 'meshes' (did you mean 'mesh'?)"},
        BadScene{"wrong_type", "[materials.soft]\nmass = \"light\"\n",
                 "s.toml:2: [materials.soft] mass: must be a number, not a string"},
        BadScene{"bool_type", "[materials.soft]\nplastic = 1\n",
                 "s.toml:2: [materials.soft] plastic: must be true or false, not an integer"},
        BadScene{"negative", "[materials.soft]\nstiffness = -5\n",
                 "s.toml:2: [materials.soft] stiffness: must be >= 0, got -5"},
        BadScene{"nan", "[simulation]\nrate_hz = nan\n", "s.toml:2: [simulation] rate_hz: must be a finite number"},
        BadScene{"enum", "[materials.soft]\nmodel = \"sprung\"\n",
                 "s.toml:2: [materials.soft] model: 'sprung' is not one of spring, linear (did you mean 'spring'?)"},
        BadScene{"substeps", "[simulation]\nsubsteps = \"many\"\n",
                 "s.toml:2: [simulation] substeps: must be \"auto\" or an integer >= 1, not 'many'"},
        BadScene{"safety", "[simulation]\nsubstep_safety = 1.5\n",
                 "s.toml:2: [simulation] substep_safety: must be in (0, 1], got 1.5"},
        BadScene{"vector", "[[tool]]\nposition = [1, 2]\n",
                 "s.toml:2: [[tool]] #1 position: must be an array of 3 numbers, like [0.0, 0.1, 0.0]"},
        BadScene{"syntax", "[simulation\nrate_hz = 1\n",
                 "s.toml:1: not valid TOML: Error while parsing table header: expected ']', saw '\\n'"},
        // Two defects of toml++ 3.3.0 that malformed input reaches (daemon/toml/toml.cpp).
        BadScene{"triple_bracket", "[[[mesh]]]\nfile = \"a.obj\"\n",
                 "s.toml: not valid TOML: the TOML parser cannot go on from here (its check "
                 "`is_bare_key_character(*cp) || is_string_delimiter(*cp)` fails)"},
        BadScene{"non_ascii_after_value", "[simulation]\nrate_hz = 1000.0\u00e2\n",
                 "s.toml:2: not valid TOML: Error while parsing floating-point: expected decimal digit, saw '\u00e2'"},
        BadScene{"mesh_not_array", "[mesh]\nfile = \"a.obj\"\n",
                 "s.toml:1: 'mesh' must be a list of tables: write [[mesh]] before each one, not [mesh]"},
        BadScene{"no_file", "[[mesh]]\nname = \"x\"\n",
                 "s.toml:1: [[mesh]] #1 needs a 'file' (a mesh file, or builtin:icosphere, builtin:torus, builtin:box)"},
        BadScene{"unknown_material", "[[mesh]]\nfile = \"builtin:box\"\nmaterial = \"jely\"\n",
                 "s.toml:3: [[mesh]] #1 material: no material 'jely' (defined: clay, jelly, rubber) (did you mean "
                 "'jelly'?)"},
        BadScene{"unknown_shape", "[[mesh]]\nfile = \"builtin:sphere\"\n",
                 "s.toml:2: [[mesh]] #1 file: no built-in shape 'sphere' (there are icosphere, torus, box)"},
        BadScene{"params_typo", "[[mesh]]\nfile = \"builtin:torus\"\nparams = { radius = 1 }\n",
                 "s.toml:3: [[mesh]] #1 params unknown key 'radius' (allowed: major_radius, minor_radius, rings, sides)"},
        BadScene{"params_on_file", "[[mesh]]\nfile = \"a.obj\"\nparams = { radius = 1 }\n",
                 "s.toml:3: [[mesh]] #1 params: only builtin: shapes take params"},
        BadScene{"torus_radii", "[[mesh]]\nfile = \"builtin:torus\"\nparams = { major_radius = 0.1, minor_radius = 0.2 }\n",
                 "s.toml:3: [[mesh]] #1 params minor_radius: must be smaller than major_radius (0.1)"},
        BadScene{"zero_scale", "[[mesh]]\nfile = \"builtin:box\"\nscale = 0\n",
                 "s.toml:3: [[mesh]] #1 scale: must not be 0 (it would flatten the mesh)"},
        BadScene{"missing_mesh_file", "[[mesh]]\nfile = \"nowhere.stl\"\n",
                 "s.toml:2: [[mesh]] #1 file: nowhere.stl: no such file"},
        BadScene{"tool_shape", "[[tool]]\nshape = \"cube\"\n",
                 "s.toml:2: [[tool]] #1 shape: 'cube' is not one of sphere, capsule"},
        BadScene{"tool_device", "[[tool]]\ndevice = 1.5\n",
                 "s.toml:2: [[tool]] #1 device: must be an index (0 = first joystick) or a name, not a number"},
        BadScene{"tool_radius", "[[tool]]\nradius = 0\n", "s.toml:2: [[tool]] #1 radius: must be > 0, got 0"},
        BadScene{"material_not_table", "[materials]\nsoft = 3\n",
                 "s.toml:2: [materials] 'soft' must be a table ([materials.soft]), not an integer"},
        BadScene{"base", "[materials.soft]\nbase = \"clya\"\n",
                 "s.toml:2: [materials.soft] base: no preset 'clya' (presets: rubber, clay, jelly) (did you mean "
                 "'clay'?)"},
        BadScene{"version", "version = 2\n", "s.toml:1: version: must be in [1, 1], got 2"}),
    [](const auto& info) { return std::string(info.param.name); });

TEST(SceneFile, MissingOrUnreadableSceneFile) {
  EXPECT_EQ(error_of<SceneError>([] { load_scene("/no/such/scene.toml"); }), "/no/such/scene.toml: no such file");
  TempDir dir;
  EXPECT_NE(error_of<SceneError>([&] { load_scene(dir.path()); }).find("is a directory"), std::string::npos);
}

TEST(SceneFile, MeshErrorsNameTheSceneLineAndTheMeshFile) {
  const auto scene = data_dir() / "scenes" / "bad" / "bad_mesh_file.toml";
  const std::string msg = error_of<SceneError>([&] { load_scene(scene); });
  EXPECT_EQ(msg.rfind(scene.string() + ":2: [[mesh]] #1 file: ", 0), 0u) << msg;
  EXPECT_NE(msg.find("nan.obj: vertex 2 has a non-finite coordinate"), std::string::npos) << msg;
}

TEST(SceneFile, PathsAreRelativeToTheSceneFile) {
  TempDir dir;
  std::filesystem::create_directories(dir / "deep" / "er");
  std::filesystem::copy_file(data_dir() / "meshes" / "icosphere.off", dir / "deep" / "ball.off");
  dir.write("deep/er/scene.toml", "[[mesh]]\nfile = \"../ball.off\"\n");
  const Scene s = load_scene(dir / "deep" / "er" / "scene.toml");
  EXPECT_EQ(s.meshes[0].loaded.report.vertices, 162u);
  EXPECT_EQ(s.meshes[0].name, "ball");
}

TEST(SceneFile, ToolsOnTheSameStickAreAWarning) {
  const Scene s = parse_scene("[[tool]]\nname = \"a\"\n[[tool]]\nname = \"b\"\n", "t.toml");
  ASSERT_EQ(s.tools.size(), 2u);
  bool found = false;
  for (const auto& w : s.warnings) found |= w == "t.toml:3: tools 'a' and 'b' follow the same stick and will move together";
  EXPECT_TRUE(found);
}

}  // namespace
}  // namespace sculpt::scene
