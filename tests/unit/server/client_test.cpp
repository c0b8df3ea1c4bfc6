// The client library without a daemon: the socket path rule and the
// MeshMirror (keyframe, deltas, changed ranges, bad frames change nothing).
#include <cstring>
#include <map>

#include <capnp/message.h>
#include <gtest/gtest.h>

#include "client/mesh_mirror.hpp"
#include "client/socket_path.hpp"

namespace sculpt::client {
namespace {

std::string path_with(std::map<std::string, std::string> env, std::string_view flag = {}) {
  return resolve_socket_path(flag, [&](const char* n) -> const char* {
    auto it = env.find(n);
    return it == env.end() ? nullptr : it->second.c_str();
  });
}

TEST(SocketPath, FlagThenSculptdSocketThenRuntimeDirectoryThenXdgThenRun) {
  const std::map<std::string, std::string> all = {
      {"SCULPTD_SOCKET", "/a/s.sock"}, {"RUNTIME_DIRECTORY", "/run/sculptd"}, {"XDG_RUNTIME_DIR", "/run/user/1000"}};
  EXPECT_EQ(path_with(all, "/flag.sock"), "/flag.sock");
  EXPECT_EQ(path_with(all), "/a/s.sock");
  EXPECT_EQ(path_with({{"RUNTIME_DIRECTORY", "/run/sculptd:/run/other"}, {"XDG_RUNTIME_DIR", "/x"}}),
            "/run/sculptd/sculptd.sock");
  EXPECT_EQ(path_with({{"XDG_RUNTIME_DIR", "/run/user/1000"}}), "/run/user/1000/sculptd/sculptd.sock");
  EXPECT_EQ(path_with({{"SCULPTD_SOCKET", ""}, {"XDG_RUNTIME_DIR", ""}}), "/run/sculptd/sculptd.sock");
  EXPECT_EQ(path_with({}), kSystemSocketPath);
}

void set_floats(capnp::Data::Builder d, std::initializer_list<float> v) { std::memcpy(d.begin(), v.begin(), v.size() * 4); }

// Two meshes: id 3 with 4 vertices, id 9 with 3.
void make_keyframe(proto::Keyframe::Builder s) {
  s.setSequence(10);
  auto meshes = s.initMeshes(2);
  meshes[0].setId(3);
  meshes[0].setName("quad");
  auto t = meshes[0].initTriangles(6);
  const std::uint32_t quad[] = {0, 1, 2, 0, 2, 3};
  for (unsigned i = 0; i < 6; ++i) t.set(i, quad[i]);
  set_floats(meshes[0].initPositions(48), {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0});
  set_floats(meshes[0].initRestPositions(48), {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0});
  meshes[1].setId(9);
  auto t2 = meshes[1].initTriangles(3);
  for (unsigned i = 0; i < 3; ++i) t2.set(i, i);
  set_floats(meshes[1].initPositions(36), {5, 5, 5, 6, 5, 5, 5, 6, 5});
  set_floats(meshes[1].initRestPositions(36), {5, 5, 5, 6, 5, 5, 5, 6, 5});
  s.initTools(1)[0].initPosition().setY(0.2f);
}

TEST(MeshMirror, AppliesAKeyframeThenDeltasAndNamesTheChangedRanges) {
  capnp::MallocMessageBuilder keyframe_msg;
  make_keyframe(keyframe_msg.initRoot<proto::Keyframe>());
  MeshMirror m(/*merge_gap=*/0);
  auto all = m.apply(keyframe_msg.getRoot<proto::Keyframe>().asReader());
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(all[0].end, 4u);
  EXPECT_EQ(all[1].end, 3u);
  EXPECT_EQ(m.meshes()[1].positions[3], 6.0f);
  EXPECT_FLOAT_EQ(m.tools()[0].position[1], 0.2f);

  capnp::MallocMessageBuilder fm;
  auto f = fm.initRoot<proto::DeltaFrame>();
  f.setSequence(12);
  f.setPublishedNs(77);
  auto d = f.initMeshes(1);
  d[0].setMeshId(3);
  auto idx = d[0].initIndices(3);
  idx.set(0, 0);
  idx.set(1, 1);
  idx.set(2, 3);
  set_floats(d[0].initPositions(36), {0, 0, 1, 1, 0, 1, 0, 1, 1});
  auto r = m.apply(f.asReader());
  ASSERT_EQ(r.size(), 2u);  // 0..2 and 3..4 with no merging
  EXPECT_EQ(r[0].mesh, 0u);
  EXPECT_EQ(r[0].begin, 0u);
  EXPECT_EQ(r[0].end, 2u);
  EXPECT_EQ(r[1].begin, 3u);
  EXPECT_EQ(r[1].end, 4u);
  EXPECT_EQ(m.meshes()[0].positions[11], 1.0f);
  EXPECT_EQ(m.meshes()[0].positions[8], 0.0f);  // vertex 2 untouched
  EXPECT_EQ(m.sequence(), 12u);
  EXPECT_EQ(m.published_ns(), 77);

  MeshMirror merging(/*merge_gap=*/8);
  merging.apply(keyframe_msg.getRoot<proto::Keyframe>().asReader());
  auto one = merging.apply(f.asReader());
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one[0].end, 4u);

  capnp::MallocMessageBuilder km;
  auto k = km.initRoot<proto::DeltaFrame>();
  k.setSequence(13);
  EXPECT_TRUE(m.apply(k.asReader()).empty());
  EXPECT_EQ(m.keepalives(), 1u);
}

TEST(MeshMirror, AFrameThatDoesNotFitTheKeyframeThrowsAndChangesNothing) {
  capnp::MallocMessageBuilder keyframe_msg;
  make_keyframe(keyframe_msg.initRoot<proto::Keyframe>());
  MeshMirror m;
  {
    capnp::MallocMessageBuilder fm;
    EXPECT_THROW(m.apply(fm.initRoot<proto::DeltaFrame>().asReader()), MirrorError);  // before a keyframe
  }
  m.apply(keyframe_msg.getRoot<proto::Keyframe>().asReader());
  auto bad = [&](auto change) {
    capnp::MallocMessageBuilder fm;
    auto f = fm.initRoot<proto::DeltaFrame>();
    auto d = f.initMeshes(2);
    d[0].setMeshId(9);
    d[0].initIndices(1).set(0, 0);
    set_floats(d[0].initPositions(12), {100, 100, 100});
    d[1].setMeshId(3);
    change(d[1]);
    EXPECT_THROW(m.apply(f.asReader()), MirrorError);
    EXPECT_EQ(m.meshes()[1].positions[0], 5.0f) << "a bad frame changed the mirror";
  };
  bad([](proto::MeshDelta::Builder d) { d.setMeshId(4); });  // unknown mesh
  bad([](proto::MeshDelta::Builder d) {                      // index out of range
    d.initIndices(1).set(0, 4);
    d.initPositions(12);
  });
  bad([](proto::MeshDelta::Builder d) {  // sizes disagree
    d.initIndices(2);
    d.initPositions(12);
  });
  bad([](proto::MeshDelta::Builder d) {  // not ascending
    auto i = d.initIndices(2);
    i.set(0, 2);
    i.set(1, 1);
    d.initPositions(24);
  });
}

}  // namespace
}  // namespace sculpt::client
