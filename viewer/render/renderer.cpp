#include "render/renderer.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <string>

#include "render/font.hpp"

namespace sculpt::view {

namespace {

// Shared lighting: a key light from above-left-front and a fill along the
// view, both two-sided so open meshes look right from behind.
constexpr const char* kLighting = R"(
vec3 shade(vec3 base, vec3 n, vec3 world, vec3 eye) {
  vec3 v = normalize(eye - world);
  if (dot(n, v) < 0.0) n = -n;
  vec3 key = normalize(vec3(-0.4, 0.9, 0.5));
  float diff = max(dot(n, key), 0.0) * 0.65 + max(dot(n, v), 0.0) * 0.30;
  vec3 h = normalize(key + v);
  float spec = pow(max(dot(n, h), 0.0), 40.0) * 0.25;
  return base * (0.18 + diff) + vec3(spec);
}
)";

const std::string kMeshVs = R"(#version 300 es
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec3 a_rest;
uniform mat4 u_view_proj;
out vec3 v_world;
out vec3 v_normal;
out float v_disp;
void main() {
  v_world = a_pos;
  v_normal = a_normal;
  v_disp = length(a_pos - a_rest);
  gl_Position = u_view_proj * vec4(a_pos, 1.0);
}
)";

const std::string kMeshFs = std::string(R"(#version 300 es
precision highp float;
in vec3 v_world;
in vec3 v_normal;
in float v_disp;
uniform vec3 u_color;
uniform vec3 u_eye;
uniform float u_colormap_range;   // <= 0: no colour map
out vec4 o_color;
vec3 ramp(float t) {   // blue, cyan, green, yellow, red
  t = clamp(t, 0.0, 1.0);
  vec3 c = mix(vec3(0.15, 0.25, 0.85), vec3(0.1, 0.8, 0.9), smoothstep(0.0, 0.25, t));
  c = mix(c, vec3(0.2, 0.85, 0.3), smoothstep(0.25, 0.5, t));
  c = mix(c, vec3(0.95, 0.85, 0.15), smoothstep(0.5, 0.75, t));
  return mix(c, vec3(0.9, 0.15, 0.1), smoothstep(0.75, 1.0, t));
}
)") + kLighting + R"(
void main() {
  vec3 base = u_colormap_range > 0.0 ? ramp(v_disp / u_colormap_range) : u_color;
  vec3 n = length(v_normal) > 0.0 ? normalize(v_normal) : vec3(0.0, 1.0, 0.0);
  o_color = vec4(shade(base, n, v_world, u_eye), 1.0);
}
)";

// Tools and arrows: a unit shape scaled, stretched along y by `side` (the
// capsule's two caps), then placed by u_model.
const std::string kSolidVs = R"(#version 300 es
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in float a_side;
uniform mat4 u_view_proj;
uniform mat4 u_model;
uniform vec3 u_scale;
uniform float u_half;
out vec3 v_world;
out vec3 v_normal;
void main() {
  vec3 p = a_pos * u_scale + vec3(0.0, a_side * u_half, 0.0);
  vec4 w = u_model * vec4(p, 1.0);
  v_world = w.xyz;
  v_normal = mat3(u_model) * (a_normal / u_scale);
  gl_Position = u_view_proj * w;
}
)";

const std::string kSolidFs = std::string(R"(#version 300 es
precision highp float;
in vec3 v_world;
in vec3 v_normal;
uniform vec4 u_color;
uniform vec3 u_eye;
out vec4 o_color;
)") + kLighting + R"(
void main() {
  o_color = vec4(shade(u_color.rgb, normalize(v_normal), v_world, u_eye), u_color.a);
}
)";

const std::string kLineVs = R"(#version 300 es
layout(location = 0) in vec3 a_pos;
uniform mat4 u_view_proj;
void main() { gl_Position = u_view_proj * vec4(a_pos, 1.0); }
)";

const std::string kLineFs = R"(#version 300 es
precision mediump float;
uniform vec4 u_color;
out vec4 o_color;
void main() { o_color = u_color; }
)";

const std::string kOverlayVs = R"(#version 300 es
layout(location = 0) in vec2 a_px;
uniform vec2 u_viewport;
void main() { gl_Position = vec4(a_px.x / u_viewport.x * 2.0 - 1.0, 1.0 - a_px.y / u_viewport.y * 2.0, 0.0, 1.0); }
)";

Eigen::Vector3f material_color(const std::string& material) {
  if (material == "rubber") return {0.85f, 0.36f, 0.26f};
  if (material == "jelly") return {0.36f, 0.74f, 0.46f};
  if (material == "clay") return {0.80f, 0.63f, 0.43f};
  static const Eigen::Vector3f palette[] = {{0.45f, 0.55f, 0.85f}, {0.75f, 0.45f, 0.80f}, {0.85f, 0.75f, 0.35f},
                                            {0.40f, 0.75f, 0.75f}};
  return palette[std::hash<std::string>{}(material) % 4];
}

void attrib(GLuint index, GLint size, GLsizei stride, std::size_t offset) {
  glEnableVertexAttribArray(index);
  glVertexAttribPointer(index, size, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(offset));
}

// The rotation taking +y to unit vector d (Rodrigues about y × d).
Eigen::Matrix3f rotation_from_y(const Eigen::Vector3f& d) {
  const Eigen::Vector3f y(0, 1, 0);
  const float c = y.dot(d);
  if (c < -0.9999f) return Eigen::Vector3f(1, -1, -1).asDiagonal();  // half a turn about x
  const Eigen::Vector3f v = y.cross(d);
  Eigen::Matrix3f k;
  k << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return Eigen::Matrix3f::Identity() + k + k * k * (1.0f / (1.0f + c));
}

void set_mat4(GLuint program, const char* name, const Eigen::Matrix4f& m) {
  glUniformMatrix4fv(glGetUniformLocation(program, name), 1, GL_FALSE, m.data());  // Eigen is column-major
}

}  // namespace

struct Renderer::GpuMesh {
  gl::VertexArray vao;
  gl::VertexArray wire_vao;
  gl::Buffer positions, normals, rest, triangles, edges;
  GLsizei index_count = 0;
  GLsizei edge_count = 0;
};

// A static shape: x,y,z, nx,ny,nz, side per vertex.
struct Renderer::Solid {
  gl::VertexArray vao;
  gl::Buffer vbo, ibo;
  GLsizei index_count = 0;
};

namespace {

struct SolidData {
  std::vector<float> v;   // 7 floats per vertex
  std::vector<std::uint32_t> i;
  void vertex(float x, float y, float z, float nx, float ny, float nz, float side) {
    v.insert(v.end(), {x, y, z, nx, ny, nz, side});
  }
  std::uint32_t count() const { return static_cast<std::uint32_t>(v.size() / 7); }
};

// A unit sphere split at the equator (the equator ring twice): upper half
// side +1, lower half side -1, so u_half stretches it into a capsule.
SolidData capsule_data() {
  constexpr int kSlices = 32, kRings = 16;  // kRings even
  constexpr float kPi = 3.14159265358979f;
  SolidData d;
  std::vector<std::pair<float, float>> rings;  // (polar angle, side)
  for (int r = 0; r <= kRings; ++r) {
    const float theta = kPi * static_cast<float>(r) / kRings;
    if (r == kRings / 2) {
      rings.push_back({theta, 1.0f});
      rings.push_back({theta, -1.0f});
    } else {
      rings.push_back({theta, r < kRings / 2 ? 1.0f : -1.0f});
    }
  }
  for (auto [theta, side] : rings) {
    for (int s = 0; s <= kSlices; ++s) {
      const float phi = 2 * kPi * static_cast<float>(s) / kSlices;
      const float x = std::sin(theta) * std::cos(phi), y = std::cos(theta), z = std::sin(theta) * std::sin(phi);
      d.vertex(x, y, z, x, y, z, side);
    }
  }
  const std::uint32_t row = kSlices + 1;
  for (std::uint32_t r = 0; r + 1 < rings.size(); ++r) {
    for (std::uint32_t s = 0; s < kSlices; ++s) {
      const std::uint32_t a = r * row + s, b = a + row;
      d.i.insert(d.i.end(), {a, a + 1, b, a + 1, b + 1, b});
    }
  }
  return d;
}

// Radius 1 from y = 0 to y = 1 (cylinder: open; cone: apex at y = 1, closed base).
SolidData lathe_data(bool cone) {
  constexpr int kSlices = 16;
  constexpr float kPi = 3.14159265358979f;
  SolidData d;
  const float ny = cone ? std::sqrt(0.5f) : 0.0f, nr = cone ? std::sqrt(0.5f) : 1.0f;
  for (int s = 0; s <= kSlices; ++s) {
    const float phi = 2 * kPi * static_cast<float>(s) / kSlices;
    const float c = std::cos(phi), sn = std::sin(phi);
    d.vertex(c, 0, sn, c * nr, ny, sn * nr, 0);
    if (cone) {
      d.vertex(0, 1, 0, c * nr, ny, sn * nr, 0);
    } else {
      d.vertex(c, 1, sn, c, 0, sn, 0);
    }
  }
  for (std::uint32_t s = 0; s < kSlices; ++s) {
    const std::uint32_t a = s * 2;
    d.i.insert(d.i.end(), {a, a + 1, a + 2, a + 1, a + 3, a + 2});
  }
  if (cone) {  // base disc
    const std::uint32_t centre = d.count();
    d.vertex(0, 0, 0, 0, -1, 0, 0);
    const std::uint32_t first = d.count();
    for (int s = 0; s <= kSlices; ++s) {
      const float phi = 2 * kPi * static_cast<float>(s) / kSlices;
      d.vertex(std::cos(phi), 0, std::sin(phi), 0, -1, 0, 0);
    }
    for (std::uint32_t s = 0; s < kSlices; ++s) d.i.insert(d.i.end(), {centre, first + s + 1, first + s});
  }
  return d;
}

}  // namespace

Renderer::Renderer() {
  mesh_program_ = gl::make_program("mesh", kMeshVs.c_str(), kMeshFs.c_str());
  solid_program_ = gl::make_program("tool", kSolidVs.c_str(), kSolidFs.c_str());
  line_program_ = gl::make_program("line", kLineVs.c_str(), kLineFs.c_str());
  overlay_program_ = gl::make_program("overlay", kOverlayVs.c_str(), kLineFs.c_str());
  for (const SolidData& d : {capsule_data(), lathe_data(false), lathe_data(true)}) {
    Solid s;
    s.vao = gl::make_vertex_array();
    s.vbo = gl::make_buffer();
    s.ibo = gl::make_buffer();
    glBindVertexArray(s.vao.get());
    glBindBuffer(GL_ARRAY_BUFFER, s.vbo.get());
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(d.v.size() * sizeof(float)), d.v.data(), GL_STATIC_DRAW);
    attrib(0, 3, 7 * sizeof(float), 0);
    attrib(1, 3, 7 * sizeof(float), 3 * sizeof(float));
    attrib(2, 1, 7 * sizeof(float), 6 * sizeof(float));
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, s.ibo.get());
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(d.i.size() * sizeof(std::uint32_t)), d.i.data(),
                 GL_STATIC_DRAW);
    s.index_count = static_cast<GLsizei>(d.i.size());
    solids_.push_back(std::move(s));
  }
  lines_vao_ = gl::make_vertex_array();
  lines_vbo_ = gl::make_buffer();
  glBindVertexArray(lines_vao_.get());
  glBindBuffer(GL_ARRAY_BUFFER, lines_vbo_.get());
  attrib(0, 3, 3 * sizeof(float), 0);
  overlay_vao_ = gl::make_vertex_array();
  overlay_vbo_ = gl::make_buffer();
  glBindVertexArray(overlay_vao_.get());
  glBindBuffer(GL_ARRAY_BUFFER, overlay_vbo_.get());
  attrib(0, 2, 2 * sizeof(float), 0);
  glBindVertexArray(0);
  gl::check("Renderer setup");
}

Renderer::~Renderer() = default;

UploadStats Renderer::sync(ViewModel& model, const RenderOptions& options) {
  UploadStats stats;
  if (model.generation != generation_ || meshes_.size() != model.meshes.size()) {
    meshes_.clear();
    generation_ = model.generation;
  }
  for (std::size_t k = 0; k < model.meshes.size(); ++k) {
    ViewMesh& mesh = model.meshes[k];
    const auto fsize = [](std::span<const float> s) { return static_cast<GLsizeiptr>(s.size_bytes()); };
    if (k >= meshes_.size()) {
      GpuMesh g;
      g.vao = gl::make_vertex_array();
      g.positions = gl::make_buffer();
      g.normals = gl::make_buffer();
      g.rest = gl::make_buffer();
      g.triangles = gl::make_buffer();
      glBindVertexArray(g.vao.get());
      glBindBuffer(GL_ARRAY_BUFFER, g.positions.get());
      glBufferData(GL_ARRAY_BUFFER, fsize(mesh.positions()), mesh.positions().data(), GL_DYNAMIC_DRAW);
      attrib(0, 3, 0, 0);
      glBindBuffer(GL_ARRAY_BUFFER, g.normals.get());
      glBufferData(GL_ARRAY_BUFFER, fsize(mesh.normals()), mesh.normals().data(), GL_DYNAMIC_DRAW);
      attrib(1, 3, 0, 0);
      glBindBuffer(GL_ARRAY_BUFFER, g.rest.get());
      glBufferData(GL_ARRAY_BUFFER, fsize(mesh.rest()), mesh.rest().data(), GL_STATIC_DRAW);
      attrib(2, 3, 0, 0);
      glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g.triangles.get());
      glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(mesh.triangles().size_bytes()),
                   mesh.triangles().data(), GL_STATIC_DRAW);
      g.index_count = static_cast<GLsizei>(mesh.triangles().size());
      glBindVertexArray(0);
      mesh.take_dirty();
      meshes_.push_back(std::move(g));
      ++stats.meshes_rebuilt;
      stats.vertices += mesh.vertex_count();
    }
    GpuMesh& g = meshes_[k];
    if (options.wireframe && !g.wire_vao) {   // built on first use: edges never change
      const auto& edges = mesh.edges();
      g.wire_vao = gl::make_vertex_array();
      g.edges = gl::make_buffer();
      glBindVertexArray(g.wire_vao.get());
      glBindBuffer(GL_ARRAY_BUFFER, g.positions.get());
      attrib(0, 3, 0, 0);
      glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g.edges.get());
      glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(edges.size() * sizeof(std::uint32_t)), edges.data(),
                   GL_STATIC_DRAW);
      g.edge_count = static_cast<GLsizei>(edges.size());
      glBindVertexArray(0);
    }
    if (!mesh.dirty()) continue;
    ViewMesh::Dirty dirty = mesh.take_dirty();
    const std::vector<Range> ranges =
        dirty.all ? std::vector<Range>{{0, static_cast<std::uint32_t>(mesh.vertex_count())}} : std::move(dirty.ranges);
    for (const auto& [buffer, data] : {std::pair{g.positions.get(), mesh.positions()}, std::pair{g.normals.get(), mesh.normals()}}) {
      glBindBuffer(GL_ARRAY_BUFFER, buffer);
      for (const Range& r : ranges) {
        glBufferSubData(GL_ARRAY_BUFFER, static_cast<GLintptr>(r.begin) * 12, static_cast<GLsizeiptr>(r.end - r.begin) * 12,
                        data.data() + std::size_t{r.begin} * 3);
      }
    }
    stats.ranges += ranges.size();
    for (const Range& r : ranges) stats.vertices += r.end - r.begin;
  }
  glBindBuffer(GL_ARRAY_BUFFER, 0);
  gl::check("Renderer::sync");
  return stats;
}

void Renderer::draw(const ViewModel& model, const Camera& camera, int width, int height, const RenderOptions& options,
                    const std::vector<std::string>& overlay) {
  const float aspect = static_cast<float>(width) / static_cast<float>(std::max(height, 1));
  view_proj_ = camera.projection(aspect) * camera.view();
  eye_ = camera.eye();
  glViewport(0, 0, width, height);
  glClearColor(0.14f, 0.15f, 0.18f, 1.0f);
  glClearDepthf(1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);
  glDisable(GL_CULL_FACE);   // open meshes show their inside
  glDisable(GL_BLEND);

  // Meshes. With the wireframe on, the faces are pushed back a little so the
  // edges drawn on top win the depth test.
  const GLuint mp = mesh_program_.get();
  glUseProgram(mp);
  set_mat4(mp, "u_view_proj", view_proj_);
  glUniform3fv(glGetUniformLocation(mp, "u_eye"), 1, eye_.data());
  glUniform1f(glGetUniformLocation(mp, "u_colormap_range"), options.colormap ? options.colormap_range_m : 0.0f);
  if (options.wireframe) {
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(1.0f, 1.0f);
  }
  for (std::size_t k = 0; k < meshes_.size() && k < model.meshes.size(); ++k) {
    const Eigen::Vector3f c = material_color(model.meshes[k].material());
    glUniform3fv(glGetUniformLocation(mp, "u_color"), 1, c.data());
    glBindVertexArray(meshes_[k].vao.get());
    glDrawElements(GL_TRIANGLES, meshes_[k].index_count, GL_UNSIGNED_INT, nullptr);
  }
  glDisable(GL_POLYGON_OFFSET_FILL);

  if (options.wireframe) {
    const GLuint lp = line_program_.get();
    glUseProgram(lp);
    set_mat4(lp, "u_view_proj", view_proj_);
    const Eigen::Vector4f wire(0.08f, 0.08f, 0.10f, 1.0f);
    glUniform4fv(glGetUniformLocation(lp, "u_color"), 1, wire.data());
    for (std::size_t k = 0; k < meshes_.size() && k < model.meshes.size(); ++k) {
      GpuMesh& g = meshes_[k];
      if (!g.wire_vao) continue;  // sync() builds it when the wireframe is on
      glBindVertexArray(g.wire_vao.get());
      glDrawElements(GL_LINES, g.edge_count, GL_UNSIGNED_INT, nullptr);
    }
  }

  if (options.boxes) {
    std::vector<float> mesh_lines, tool_lines;
    const auto box = [](const Aabb& b, std::vector<float>& out) {
      if (b.empty()) return;
      const float x[2] = {b.min[0], b.max[0]}, y[2] = {b.min[1], b.max[1]}, z[2] = {b.min[2], b.max[2]};
      for (int i = 0; i < 2; ++i) {
        for (int j = 0; j < 2; ++j) {
          out.insert(out.end(), {x[0], y[i], z[j], x[1], y[i], z[j]});
          out.insert(out.end(), {x[i], y[0], z[j], x[i], y[1], z[j]});
          out.insert(out.end(), {x[i], y[j], z[0], x[i], y[j], z[1]});
        }
      }
    };
    for (const auto& m : model.meshes) box(m.bounds(), mesh_lines);
    if (options.tools) {
      for (const auto& t : model.tools) box(t.bounds(), tool_lines);
    }
    draw_lines(mesh_lines, {0.95f, 0.85f, 0.25f, 1.0f});
    draw_lines(tool_lines, {0.35f, 0.85f, 0.95f, 1.0f});
  }

  // Tools, see-through so the dent under them stays visible; then the arrows.
  if (options.tools && !model.tools.empty()) {
    glEnable(GL_BLEND);
    glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ZERO, GL_ONE);  // keep the target opaque
    glDepthMask(GL_FALSE);
    for (const auto& t : model.tools) {
      Eigen::Matrix4f m = Eigen::Matrix4f::Identity();
      const Eigen::Quaternionf q(t.orientation[0], t.orientation[1], t.orientation[2], t.orientation[3]);
      // The capsule mesh runs along its local y; the protocol's axis is orientation·(+x).
      Eigen::Matrix3f y_to_x;
      y_to_x << 0, 1, 0, -1, 0, 0, 0, 0, 1;
      m.block<3, 3>(0, 0) = q.normalized().toRotationMatrix() * y_to_x;
      m.block<3, 1>(0, 3) = Eigen::Vector3f(t.position[0], t.position[1], t.position[2]);
      const Eigen::Vector4f color = t.grabbing ? Eigen::Vector4f(0.95f, 0.55f, 0.15f, 0.55f)
                                               : Eigen::Vector4f(0.55f, 0.70f, 0.95f, 0.45f);
      const float half = t.shape == ToolShape::capsule ? t.half_length : 0.0f;
      draw_solid(solids_[0], m, Eigen::Vector3f::Constant(t.radius), half, color);
    }
    glDepthMask(GL_TRUE);
    glDisable(GL_BLEND);
    if (options.arrows) {
      for (const auto& t : model.tools) {
        const Eigen::Vector3f f(t.force[0], t.force[1], t.force[2]);
        const float n = f.norm();
        if (!(n > options.arrow_min_n)) continue;
        // Starts at the centre and always leaves the tool, then grows with the force.
        const float length = std::min(t.radius * 1.3f + 0.005f + n * options.arrow_m_per_n, options.arrow_max_m);
        const float head = std::min(length * 0.35f, t.radius * 1.2f + 0.004f);
        const float shaft_r = std::max(head * 0.18f, 0.0015f);
        Eigen::Matrix4f m = Eigen::Matrix4f::Identity();
        m.block<3, 3>(0, 0) = rotation_from_y(f / n);
        m.block<3, 1>(0, 3) = Eigen::Vector3f(t.position[0], t.position[1], t.position[2]);
        const Eigen::Vector4f red(0.95f, 0.2f, 0.15f, 1.0f);
        draw_solid(solids_[1], m, {shaft_r, length - head, shaft_r}, 0.0f, red);
        Eigen::Matrix4f tip = m;
        tip.block<3, 1>(0, 3) += m.block<3, 3>(0, 0) * Eigen::Vector3f(0, length - head, 0);
        draw_solid(solids_[2], tip, {head * 0.45f, head, head * 0.45f}, 0.0f, red);
      }
    }
  }

  if (options.overlay && !overlay.empty()) draw_overlay(overlay, width, height);
  glBindVertexArray(0);
  gl::check("Renderer::draw");
}

void Renderer::draw_solid(const Solid& solid, const Eigen::Matrix4f& model, const Eigen::Vector3f& scale,
                          float half_length, const Eigen::Vector4f& color) {
  const GLuint p = solid_program_.get();
  glUseProgram(p);
  set_mat4(p, "u_view_proj", view_proj_);
  set_mat4(p, "u_model", model);
  glUniform3fv(glGetUniformLocation(p, "u_scale"), 1, scale.data());
  glUniform1f(glGetUniformLocation(p, "u_half"), half_length);
  glUniform4fv(glGetUniformLocation(p, "u_color"), 1, color.data());
  glUniform3fv(glGetUniformLocation(p, "u_eye"), 1, eye_.data());
  glBindVertexArray(solid.vao.get());
  glDrawElements(GL_TRIANGLES, solid.index_count, GL_UNSIGNED_INT, nullptr);
}

void Renderer::draw_lines(const std::vector<float>& xyz, const Eigen::Vector4f& color) {
  if (xyz.empty()) return;
  const GLuint p = line_program_.get();
  glUseProgram(p);
  set_mat4(p, "u_view_proj", view_proj_);
  glUniform4fv(glGetUniformLocation(p, "u_color"), 1, color.data());
  glBindVertexArray(lines_vao_.get());
  glBindBuffer(GL_ARRAY_BUFFER, lines_vbo_.get());
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(xyz.size() * sizeof(float)), xyz.data(), GL_STREAM_DRAW);
  glDrawArrays(GL_LINES, 0, static_cast<GLsizei>(xyz.size() / 3));
}

void Renderer::draw_overlay(const std::vector<std::string>& lines, int width, int height) {
  const int scale = height >= 600 ? 2 : 1;
  std::vector<font::Rect> rects;
  std::size_t longest = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    longest = std::max(longest, lines[i].size());
    font::layout(lines[i], 8.0f * scale, 8.0f * scale + static_cast<float>(i * font::kLine * scale), scale, rects);
  }
  const auto quads = [](const std::vector<font::Rect>& rs) {
    std::vector<float> v;
    v.reserve(rs.size() * 12);
    for (const auto& r : rs) {
      const float x0 = r.x, y0 = r.y, x1 = r.x + r.w, y1 = r.y + r.h;
      v.insert(v.end(), {x0, y0, x1, y0, x1, y1, x0, y0, x1, y1, x0, y1});
    }
    return v;
  };
  const float s = static_cast<float>(scale);
  const std::vector<font::Rect> panel = {
      {4.0f * s, 4.0f * s, (static_cast<float>(longest * font::kAdvance) + 8.0f) * s,
       (static_cast<float>(lines.size() * font::kLine) + 6.0f) * s}};
  glDisable(GL_DEPTH_TEST);
  glEnable(GL_BLEND);
  glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ZERO, GL_ONE);  // keep the target opaque
  const GLuint p = overlay_program_.get();
  glUseProgram(p);
  glUniform2f(glGetUniformLocation(p, "u_viewport"), static_cast<float>(width), static_cast<float>(height));
  glBindVertexArray(overlay_vao_.get());
  glBindBuffer(GL_ARRAY_BUFFER, overlay_vbo_.get());
  for (const auto& [rs, color] : {std::pair{panel, Eigen::Vector4f(0.0f, 0.0f, 0.0f, 0.55f)},
                                  std::pair{rects, Eigen::Vector4f(0.92f, 0.94f, 0.96f, 1.0f)}}) {
    const std::vector<float> v = quads(rs);
    if (v.empty()) continue;
    glUniform4fv(glGetUniformLocation(p, "u_color"), 1, color.data());
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(v.size() * sizeof(float)), v.data(), GL_STREAM_DRAW);
    glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(v.size() / 2));
  }
  glDisable(GL_BLEND);
  glEnable(GL_DEPTH_TEST);
}

}  // namespace sculpt::view
