// The wire protocol compiles, its later minors only added methods after the
// old ones, and a delta frame survives a trip through the unpacked stream
// encoding the server uses.
#include <gtest/gtest.h>

#include <capnp/message.h>
#include <capnp/schema.h>
#include <capnp/serialize.h>
#include <kj/io.h>

#include <cstring>
#include <iterator>
#include <vector>

#include "sculpt.capnp.h"

TEST(Proto, VersionConstants) {
  EXPECT_EQ(sculpt::proto::PROTOCOL_MAJOR, 1);
  EXPECT_GE(sculpt::proto::PROTOCOL_MINOR, 0);
}

TEST(Proto, MethodsKeepTheirOrdinalsAndEachMinorAppendsItsOwn) {
  // A method's ordinal is what goes on the wire: an old client's call must
  // still reach the same method.
  const auto session = capnp::Schema::from<sculpt::proto::Session>();
  const char* methods[] = {"status", "devices", "keyframe", "subscribe", "loadScene", "reset",
                           "pause",  "resume",  "undo",     "redo",      "history",   "exportSculpt",
                           "tuneHaptics"};
  ASSERT_EQ(session.getMethods().size(), std::size(methods));
  for (unsigned i = 0; i < std::size(methods); ++i)
    EXPECT_EQ(session.getMethodByName(methods[i]).getOrdinal(), i) << methods[i];
  EXPECT_EQ(capnp::Schema::from<sculpt::proto::ExportReader>().getMethodByName("read").getOrdinal(), 0u);
  EXPECT_EQ(capnp::Schema::from<sculpt::proto::Viewer>().getMethodByName("keyframe").getOrdinal(), 0u);
  EXPECT_EQ(capnp::Schema::from<sculpt::proto::Viewer>().getMethodByName("frame").getOrdinal(), 1u);
  // Keyframe was named Snapshot: it keeps that name's type ID.
  EXPECT_EQ(capnp::typeId<sculpt::proto::Keyframe>(), 0x826e371020de7da3u);
  EXPECT_EQ(capnp::Schema::from<sculpt::proto::Sculptd>().getMethodByName("hello").getOrdinal(), 0u);
  EXPECT_GE(sculpt::proto::PROTOCOL_MINOR, 6) << "tuneHaptics came with minor 6";
}

TEST(Proto, DeltaFrameRoundTrip) {
  capnp::MallocMessageBuilder builder;
  auto frame = builder.initRoot<sculpt::proto::DeltaFrame>();
  frame.setSequence(42);
  frame.setSimTimeNs(1'000'000);
  auto meshes = frame.initMeshes(1);
  meshes[0].setMeshId(7);
  auto idx = meshes[0].initIndices(2);
  idx.set(0, 3);
  idx.set(1, 9);
  const float xyz[6] = {1.f, 2.f, 3.f, -4.f, 5.5f, 6.25f};
  meshes[0].setPositions(kj::arrayPtr(reinterpret_cast<const kj::byte*>(xyz), sizeof xyz));

  kj::VectorOutputStream out;
  capnp::writeMessage(out, builder);
  auto bytes = out.getArray();

  kj::ArrayInputStream in(bytes);
  capnp::InputStreamMessageReader reader(in);
  auto got = reader.getRoot<sculpt::proto::DeltaFrame>();
  EXPECT_EQ(got.getSequence(), 42u);
  ASSERT_EQ(got.getMeshes().size(), 1u);
  auto m = got.getMeshes()[0];
  EXPECT_EQ(m.getMeshId(), 7u);
  ASSERT_EQ(m.getIndices().size(), 2u);
  EXPECT_EQ(m.getIndices()[1], 9u);
  auto data = m.getPositions();
  ASSERT_EQ(data.size(), sizeof xyz);
  float back[6];
  std::memcpy(back, data.begin(), sizeof back);
  EXPECT_FLOAT_EQ(back[4], 5.5f);
}
