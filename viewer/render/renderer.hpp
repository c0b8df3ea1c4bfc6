// Draws a ViewModel with GLES 3: meshes smooth-shaded (normals from the
// current positions), optional wireframe, displacement colour map and
// bounding boxes, the tools, their contact forces as arrows, and a text
// overlay. Needs a current GLES 3 context (headless or a window).
#pragma once

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "gl/gles.hpp"
#include "render/camera.hpp"
#include "render/model.hpp"

namespace sculpt::view {

struct RenderOptions {
  bool wireframe = false;
  bool boxes = false;
  bool colormap = false;
  bool tools = true;
  bool arrows = true;
  bool overlay = true;
  float colormap_range_m = 0.02f;   // displacement drawn fully red
  float arrow_m_per_n = 0.05f;      // arrow length per newton of contact force (sculpting forces are 0.02-1 N)
  float arrow_max_m = 0.08f;
  float arrow_min_n = 0.02f;        // no arrow below (haptics' dead band)
};

// What the last sync() uploaded: for the benchmark and the tests.
struct UploadStats {
  std::size_t meshes_rebuilt = 0;
  std::size_t ranges = 0;
  std::size_t vertices = 0;
};

class Renderer {
 public:
  Renderer();   // compiles the shaders: throws gl::GlError when the driver refuses
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Brings the GPU copies up to date: whole buffers for new meshes (a new
  // keyframe), glBufferSubData over the dirty ranges otherwise; the
  // wireframe's edge buffers when options.wireframe asks for them.
  UploadStats sync(ViewModel& model, const RenderOptions& options);

  // Draws into the bound framebuffer (viewport width x height). `overlay`
  // lines appear top left.
  void draw(const ViewModel& model, const Camera& camera, int width, int height, const RenderOptions& options,
            const std::vector<std::string>& overlay);

 private:
  struct GpuMesh;
  struct Solid;
  void draw_solid(const Solid& solid, const Eigen::Matrix4f& model, const Eigen::Vector3f& scale, float half_length,
                  const Eigen::Vector4f& color);
  void draw_lines(const std::vector<float>& xyz, const Eigen::Vector4f& color);
  void draw_overlay(const std::vector<std::string>& lines, int width, int height);

  gl::Program mesh_program_;
  gl::Program solid_program_;
  gl::Program line_program_;
  gl::Program overlay_program_;
  std::vector<GpuMesh> meshes_;
  std::uint64_t generation_ = ~std::uint64_t{0};
  std::vector<Solid> solids_;   // 0: capsule/sphere, 1: cylinder, 2: cone
  gl::VertexArray lines_vao_;
  gl::Buffer lines_vbo_;
  gl::VertexArray overlay_vao_;
  gl::Buffer overlay_vbo_;
  Eigen::Matrix4f view_proj_ = Eigen::Matrix4f::Identity();
  Eigen::Vector3f eye_{0, 0, 1};
};

}  // namespace sculpt::view
