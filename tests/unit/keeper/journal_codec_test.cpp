// Journal entries survive the trip through the store's bytes; bytes that are
// not an entry are refused by name, never misread.
#include <gtest/gtest.h>

#include <linux/input.h>

#include "keeper/journal_codec.hpp"

namespace sculpt::daemon {
namespace {

JournalEntry round_trip(const JournalEntry& e) {
  std::vector<std::byte> bytes;
  encode_entry(e, bytes);
  std::string error;
  auto back = decode_entry(bytes, e.tick, error);
  EXPECT_TRUE(back) << error;
  return back.value_or(JournalEntry{});
}

TEST(JournalCodec, EveryKindComesBack) {
  input::DeviceBinding b;
  input::AxisBinding a;
  a.code = ABS_X;
  a.tool = 1;
  a.scale = -1.0f;
  b.add_axis(a);
  b.tool_mask = 2;
  JournalEntry attach{JournalEntry::Kind::message, false, 17, 0, 0, input::InputMessage::attach(3, b)};
  const JournalEntry got = round_trip(attach);
  EXPECT_EQ(got.kind, JournalEntry::Kind::message);
  EXPECT_EQ(got.tick, 17u);
  EXPECT_EQ(got.message.kind, input::MessageKind::attach);
  EXPECT_EQ(got.message.slot, 3);
  EXPECT_EQ(got.message.binding.axis_count, 1);
  EXPECT_EQ(got.message.binding.axes[0].code, ABS_X);
  EXPECT_EQ(got.message.binding.axes[0].scale, -1.0f);
  EXPECT_EQ(got.message.binding.tool_mask, 2u);

  input::InputFrame f;
  f.slot = 2;
  f.push({EV_ABS, ABS_Y, -300});
  f.push({EV_KEY, BTN_SOUTH, 1});
  JournalEntry frame{JournalEntry::Kind::message, false, 99, 0, 0, input::InputMessage::of_frame(f)};
  const JournalEntry fg = round_trip(frame);
  EXPECT_EQ(fg.message.kind, input::MessageKind::frame);
  EXPECT_EQ(fg.message.slot, 2);
  ASSERT_EQ(fg.message.frame.count, 2);
  EXPECT_EQ(fg.message.frame.events[0], (input::InputEvent{EV_ABS, ABS_Y, -300}));
  EXPECT_EQ(fg.message.frame.events[1], (input::InputEvent{EV_KEY, BTN_SOUTH, 1}));

  EXPECT_EQ(round_trip({JournalEntry::Kind::message, false, 5, 0, 0, input::InputMessage::detach(7)}).message.kind,
            input::MessageKind::detach);
  EXPECT_EQ(round_trip({JournalEntry::Kind::pause, false, 5, 0, 0, {}}).kind, JournalEntry::Kind::pause);
  EXPECT_EQ(round_trip({JournalEntry::Kind::resume, false, 5, 0, 0, {}}).kind, JournalEntry::Kind::resume);
  const JournalEntry move = round_trip({JournalEntry::Kind::history_move, true, 8, 42, 0, {}});
  EXPECT_TRUE(move.refused);
  EXPECT_EQ(move.number, 42u);
  EXPECT_EQ(round_trip({JournalEntry::Kind::scene, false, 9, 3, 0, {}}).number, 3u);
  const JournalEntry mark = round_trip({JournalEntry::Kind::reached, false, 10, 0, 1764037702371000000, {}});
  EXPECT_EQ(mark.kind, JournalEntry::Kind::reached);
  EXPECT_EQ(mark.wall_ns, 1764037702371000000);
}

TEST(JournalCodec, AFrameKeepsOnlyItsEvents) {
  input::InputFrame f;
  f.push({EV_ABS, ABS_X, 1});
  std::vector<std::byte> bytes;
  encode_entry({JournalEntry::Kind::message, false, 1, 0, 0, input::InputMessage::of_frame(f)}, bytes);
  EXPECT_LT(bytes.size(), 16u);  // kind, message kind, slot, count, one event
}

TEST(JournalCodec, BytesThatAreNotAnEntryAreRefusedByName) {
  input::InputFrame f;
  f.push({EV_ABS, ABS_X, 1});
  std::vector<std::byte> bytes;
  encode_entry({JournalEntry::Kind::message, false, 1, 0, 0, input::InputMessage::of_frame(f)}, bytes);
  std::string error;
  for (std::size_t cut = 0; cut < bytes.size(); ++cut) {
    EXPECT_FALSE(decode_entry(std::span(bytes).first(cut), 1, error)) << cut;
    EXPECT_NE(error.find("truncated"), std::string::npos) << error;
  }
  auto longer = bytes;
  longer.push_back(std::byte{0});
  EXPECT_FALSE(decode_entry(longer, 1, error));
  EXPECT_NE(error.find("left over"), std::string::npos) << error;
  std::vector<std::byte> unknown{std::byte{200}};
  EXPECT_FALSE(decode_entry(unknown, 1, error));
  EXPECT_NE(error.find("unknown entry kind"), std::string::npos) << error;
  std::vector<std::byte> bad_slot = bytes;
  bad_slot[2] = std::byte{input::kMaxDevices};
  EXPECT_FALSE(decode_entry(bad_slot, 1, error));
  EXPECT_NE(error.find("slot"), std::string::npos) << error;
}

}  // namespace
}  // namespace sculpt::daemon
