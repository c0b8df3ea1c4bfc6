// The renderer in-process on a headless context: a delta is uploaded over
// its dirty ranges only, and the picture after those partial uploads equals
// the picture of a model built afresh with the same positions.
#include <gtest/gtest.h>

#include "app/source.hpp"
#include "gl/egl_headless.hpp"
#include "gl/fbo.hpp"
#include "image_compare.hpp"
#include "render/renderer.hpp"

namespace sculpt::view {
namespace {

class Render : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { context_ = new gl::HeadlessContext(); }
  static void TearDownTestSuite() {
    delete context_;
    context_ = nullptr;
  }

  Image draw(Renderer& r, ViewModel& m, const RenderOptions& o = {}) {
    r.sync(m, o);
    fbo_.bind();
    Camera c;
    c.fit(m.scene_bounds, 320.0f / 180.0f);
    r.draw(m, c, 320, 180, o, {"TEST"});
    return Image{320, 180, fbo_.read_rgba()};
  }

  static gl::HeadlessContext* context_;
  gl::Fbo fbo_{320, 180, 0};
};

gl::HeadlessContext* Render::context_ = nullptr;

TEST_F(Render, DeltaUploadsOnlyItsRangesAndDrawsLikeAFreshModel) {
  ViewModel model;
  fill_from_scene_file(model, "builtin:default");
  Renderer renderer;
  const UploadStats first = renderer.sync(model, {});
  EXPECT_EQ(first.meshes_rebuilt, model.meshes.size());
  const Image before = draw(renderer, model);
  EXPECT_GT(viewtest::content_fraction(before), 0.05);

  // Push a patch of the ball's vertices towards its centre (a dent).
  ViewMesh& ball = model.meshes[0];
  std::vector<std::uint32_t> idx;
  std::vector<float> xyz;
  const auto p = ball.positions();
  for (std::uint32_t v = 0; v < ball.vertex_count(); ++v) {
    if (p[v * 3 + 1] > 0.03f) {  // the top cap (the ball is centred at y = 0, radius 0.07)
      idx.push_back(v);
      xyz.insert(xyz.end(), {p[v * 3], p[v * 3 + 1] * 0.4f, p[v * 3 + 2]});
    }
  }
  ASSERT_GT(idx.size(), 20u);
  ASSERT_LT(idx.size(), ball.vertex_count() / 2);
  ball.set_positions(idx, xyz);
  const UploadStats delta = renderer.sync(model, {});
  EXPECT_EQ(delta.meshes_rebuilt, 0u);
  EXPECT_GE(delta.ranges, 1u);
  EXPECT_GE(delta.vertices, idx.size());
  EXPECT_LT(delta.vertices, ball.vertex_count());   // not the whole mesh
  const Image after = draw(renderer, model);
  EXPECT_GT(viewtest::compare(before, after).bad_fraction, 0.001) << "the dent is not drawn";
  EXPECT_EQ(renderer.sync(model, {}).vertices, 0u);  // nothing left to upload

  // The same positions in a model built afresh (whole-buffer uploads).
  ViewModel fresh;
  fill_from_scene_file(fresh, "builtin:default");
  std::vector<float> all(ball.positions().begin(), ball.positions().end());
  fresh.meshes[0].set_all_positions(all);
  Renderer other;
  const Image again = draw(other, fresh);
  const auto d = viewtest::compare(after, again, 8);
  EXPECT_EQ(d.bad_fraction, 0.0) << viewtest::describe(d);
}

TEST_F(Render, NewGenerationRebuildsEveryBuffer) {
  ViewModel model;
  fill_from_scene_file(model, "builtin:default");
  Renderer renderer;
  renderer.sync(model, {});
  model.generation += 1;
  EXPECT_EQ(renderer.sync(model, {}).meshes_rebuilt, model.meshes.size());
}

TEST_F(Render, EveryOptionDraws) {
  ViewModel model;
  fill_from_scene_file(model, "builtin:default");
  model.tools[0].force = {0.0f, 0.5f, 0.0f};
  Renderer renderer;
  RenderOptions all;
  all.wireframe = all.boxes = all.colormap = true;
  const Image a = draw(renderer, model, all);
  const Image plain = draw(renderer, model, {});
  EXPECT_GT(viewtest::compare(a, plain).bad_fraction, 0.01);
}

}  // namespace
}  // namespace sculpt::view
