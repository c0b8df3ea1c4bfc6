// The recording format (recorded input files, input/recording.hpp): round
// trips, and errors that name file, line and field.
#include <gtest/gtest.h>

#include <filesystem>

#include "input/recording.hpp"
#include "test_devices.hpp"

namespace sculpt::input {
namespace {

using testing::write_file;

Recording sample() {
  Recording s;
  s.header.description = "two devices, a few moves";
  s.header.devices = {testing::gamepad(), testing::flight_stick()};
  s.header.devices[1].has_msc_timestamp = true;
  s.frames = {
      {0, 0, {{EV_ABS, ABS_X, 1200}, {EV_ABS, ABS_Y, -400}}},
      {1500, 1, {{EV_KEY, BTN_TRIGGER, 1}}},
      {1500, 0, {{EV_ABS, ABS_RX, -32768}}},
      {20000, 1, {{EV_ABS, ABS_RZ, 200}, {EV_KEY, BTN_TRIGGER, 0}}},
  };
  return s;
}

std::string error_of(const std::string& name, const std::string& text) {
  const auto p = write_file(name, text);
  try {
    read_recording(p);
  } catch (const RecordingError& e) {
    return e.what();
  }
  return "(no error)";
}

const std::string kHeader =
    R"({"format":"sculpt-session","version":1,"devices":[{"name":"pad","vendor":1,"product":2,"axes":[{"code":"ABS_X","min":-10,"max":10},{"code":1,"min":-10,"max":10}],"buttons":["BTN_SOUTH"]}]})";

TEST(Recording, RoundTrip) {
  const Recording s = sample();
  const auto p = testing::temp_file("roundtrip.jsonl");
  write_recording(p, s);
  const Recording r = read_recording(p);
  EXPECT_EQ(r.header.description, s.header.description);
  ASSERT_EQ(r.header.devices.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    DeviceInfo expect = s.header.devices[i];
    expect.node.clear();  // not part of a recording
    EXPECT_EQ(r.header.devices[i], expect) << i;
  }
  EXPECT_EQ(r.frames, s.frames);
}

TEST(Recording, HeaderNamesCodesReadably) {
  const std::string h = header_to_json(sample().header);
  EXPECT_NE(h.find(R"("format":"sculpt-session")"), std::string::npos);
  EXPECT_NE(h.find(R"("ABS_RX")"), std::string::npos);
  EXPECT_NE(h.find(R"("FF_RUMBLE")"), std::string::npos);
  EXPECT_NE(h.find(R"("BTN_TRIGGER")"), std::string::npos);
}

TEST(Recording, MinimalHeaderAndBlankLinesAreFine) {
  const auto p = write_file("minimal.jsonl", kHeader + "\n[0,0,[[3,0,5]]]\n\n[10,0,[]]\n");
  const Recording s = read_recording(p);
  ASSERT_EQ(s.frames.size(), 2u);
  EXPECT_EQ(s.header.devices[0].kind, DeviceKind::gamepad) << "classified from its capabilities";
  EXPECT_EQ(s.frames[0].events[0], (InputEvent{EV_ABS, ABS_X, 5}));
}

TEST(Recording, Errors) {
  EXPECT_NE(error_of("e1", "").find("e1:1: empty file"), std::string::npos);
  EXPECT_NE(error_of("e2", "not json\n").find("e2:1: the header is not valid JSON"), std::string::npos);
  EXPECT_NE(error_of("e3", R"({"format":"other","version":1,"devices":[]})").find("not a recording"),
            std::string::npos);
  EXPECT_NE(error_of("e4", R"({"format":"sculpt-session","version":7,"devices":[]})").find("version 7 is not supported"),
            std::string::npos);
  EXPECT_NE(error_of("e5", R"({"format":"sculpt-session","version":1,"devices":[]})").find("'devices' is empty"),
            std::string::npos);
  EXPECT_NE(error_of("e6", R"({"format":"sculpt-session","version":1,"devices":[{"vendor":1,"product":2}]})")
                .find("e6:1: devices[0]: missing field 'name'"),
            std::string::npos);
  EXPECT_NE(error_of("e7", R"({"format":"sculpt-session","version":1,"devices":[{"name":"x","vendor":1,"product":2,"axes":[{"code":"ABS_WHAT","min":0,"max":1}]}]})")
                .find("devices[0].axes[0].code: unknown event code name 'ABS_WHAT'"),
            std::string::npos);
  EXPECT_NE(error_of("e8", R"({"format":"sculpt-session","version":1,"devices":[{"name":"x","vendor":1,"product":2,"ff":["FF_RUMBLE"]}]})")
                .find("ff_effects_max"),
            std::string::npos);
  EXPECT_NE(error_of("e9", R"({"format":"sculpt-session","version":1,"devices":[{"name":"x","vendor":99999,"product":2}]})")
                .find("'vendor' = 99999 is out of range"),
            std::string::npos);
  EXPECT_NE(error_of("f1", kHeader + "\n[0,0,[[3,0,5]]]\n[0,3,[]]\n").find("f1:3: device 3 does not exist"),
            std::string::npos);
  EXPECT_NE(error_of("f2", kHeader + "\n[100,0,[]]\n[50,0,[]]\n").find("f2:3: t_us 50 is earlier"),
            std::string::npos);
  EXPECT_NE(error_of("f3", kHeader + "\n[0,0,[[3,0]]]\n").find("f3:2: event 0 must be [type, code, value]"),
            std::string::npos);
  EXPECT_NE(error_of("f4", kHeader + "\n{\"t\":1}\n").find("f4:2: a frame must be"), std::string::npos);
  EXPECT_NE(error_of("f5", kHeader + "\n[-1,0,[]]\n").find("t_us must be a non-negative"), std::string::npos);
  EXPECT_NE(error_of("f6", kHeader + "\n[0,0,[[3,0,5]]\n").find("f6:2: not valid JSON"), std::string::npos);
  EXPECT_NE(error_of("f7", kHeader + "\n[0,0,[[3,0,99999999999]]]\n").find("value 99999999999 out of range"),
            std::string::npos);
  // Past int64: named as written, not as some clamped or wrapped number.
  EXPECT_NE(error_of("f8", kHeader + "\n[0,0,[[3,0,18446744073709551615]]]\n")
                .find("f8:2: event 0: value 18446744073709551615 out of range"),
            std::string::npos);
  EXPECT_NE(error_of("f9", kHeader + "\n[0,18446744073709551615,[]]\n").find("device 18446744073709551615 does not"),
            std::string::npos);
}

TEST(Recording, ShippedRecordingsRead) {
  std::size_t n = 0;
  for (const auto& e : std::filesystem::directory_iterator(SCULPT_RECORDINGS_DIR)) {
    if (e.path().extension() != ".jsonl") continue;
    ++n;
    const Recording s = read_recording(e.path());
    EXPECT_EQ(s.header.devices.size(), 1u) << e.path();
    EXPECT_EQ(s.header.devices[0].kind, DeviceKind::gamepad) << e.path();
    EXPECT_FALSE(s.header.description.empty()) << e.path();
    ASSERT_GT(s.frames.size(), 1000u) << e.path();
    EXPECT_GE(s.frames.back().t_us, 5'000'000) << e.path() << ": recordings are 5 s or longer";
  }
  EXPECT_GE(n, 3u) << "push, pull and two_hands at least, in " << SCULPT_RECORDINGS_DIR;
}

TEST(Recording, FastAndFullParsersAgree) {
  // Spacing, negative values, empty event lists: the fast path or the JSON
  // parser, the same frame.
  for (const std::string line : {"[0,0,[[3,0,-5],[1,304,1]]]", " [ 12 , 0 , [ [3, 1, 7] ] ] ", "[5,0,[]]",
                                 "[7,0,[[3,0,1]],]", "[7,0,[[3,0,1.5]]]", "[1e3,0,[]]"}) {
    std::string fast_or_error, json_or_error;
    try {
      const RecordingFrame f = frame_from_json(line, "x", 1);
      fast_or_error = frame_to_json(f);
    } catch (const RecordingError& e) {
      fast_or_error = std::string("error: ") + e.what();
    }
    EXPECT_FALSE(fast_or_error.empty()) << line;
    if (line == "[0,0,[[3,0,-5],[1,304,1]]]" || line == "[5,0,[]]") {
      EXPECT_EQ(fast_or_error, line);
    }
    if (line[1] == '7' || line[1] == '1') {
      EXPECT_EQ(fast_or_error.rfind("error: x: ", 0), 0u) << fast_or_error;
    }
  }
  EXPECT_EQ(frame_to_json(frame_from_json(" [ 12 , 0 , [ [3, 1, 7] ] ] ", "x", 1)), "[12,0,[[3,1,7]]]");
}

TEST(Recording, MissingFileNamesIt) {
  try {
    RecordingReader r("/nonexistent/recording.jsonl");
    FAIL();
  } catch (const RecordingError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/recording.jsonl"), std::string::npos);
  }
}

TEST(Recording, WriterKeepsTimeMonotonic) {
  const auto p = testing::temp_file("mono.jsonl");
  RecordingHeader h;
  h.devices = {testing::gamepad()};
  RecordingWriter w(p, h);
  const InputEvent e{EV_ABS, ABS_X, 1};
  w.write(100, 0, &e, 1);
  w.write(90, 0, &e, 1);  // a clock step backwards is clamped, not written
  w.close();
  const Recording s = read_recording(p);
  ASSERT_EQ(s.frames.size(), 2u);
  EXPECT_EQ(s.frames[1].t_us, 100);
  EXPECT_THROW(RecordingWriter(p, RecordingHeader{}), RecordingError);
}

}  // namespace
}  // namespace sculpt::input
