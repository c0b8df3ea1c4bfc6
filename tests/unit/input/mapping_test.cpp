// Default mappings per kind of device, per-device overrides from the config,
// and binding devices to tools.
#include <gtest/gtest.h>

#include <algorithm>

#include "input/control_mapper.hpp"
#include "input/mapping.hpp"
#include "test_devices.hpp"

namespace sculpt::input {
namespace {

const AxisBinding* find_axis(const DeviceBinding& b, std::uint16_t code) {
  for (std::size_t i = 0; i < b.axis_count; ++i)
    if (b.axes[i].code == code) return &b.axes[i];
  return nullptr;
}
const ButtonBinding* find_button(const DeviceBinding& b, std::uint16_t code) {
  for (std::size_t i = 0; i < b.button_count; ++i)
    if (b.buttons[i].code == code) return &b.buttons[i];
  return nullptr;
}

MappingConfig parse(const std::string& text) {
  return parse_mapping(toml::parse(text, std::string_view("test.conf")), "test.conf");
}

std::string parse_error(const std::string& text) {
  try {
    parse(text);
  } catch (const MappingError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(DefaultMapping, GamepadTwoSticksDriveTwoTools) {
  const DeviceInfo pad = testing::gamepad();
  const DeviceBinding b =
      make_binding(pad, default_mapping(pad), {{0, Stick::left}, {1, Stick::right}});
  ASSERT_NE(find_axis(b, ABS_X), nullptr);
  EXPECT_EQ(find_axis(b, ABS_X)->tool, 0);
  EXPECT_EQ(find_axis(b, ABS_X)->component, 0);
  EXPECT_EQ(find_axis(b, ABS_Y)->tool, 0);
  EXPECT_EQ(find_axis(b, ABS_Y)->component, 1);
  EXPECT_EQ(find_axis(b, ABS_Y)->scale, -1.0f) << "stick up (negative) moves the tool up";
  EXPECT_EQ(find_axis(b, ABS_Z)->component, 2);
  EXPECT_TRUE(find_axis(b, ABS_Z)->calibration.unipolar);
  EXPECT_EQ(find_axis(b, ABS_RX)->tool, 1);
  EXPECT_EQ(find_axis(b, ABS_RY)->tool, 1);
  EXPECT_EQ(find_axis(b, ABS_RZ)->tool, 1);
  // Buttons per hand.
  EXPECT_EQ(find_button(b, BTN_SOUTH)->tool, 1);
  EXPECT_EQ(find_button(b, BTN_SOUTH)->action, ButtonAction::grab);
  EXPECT_EQ(find_button(b, BTN_EAST)->action, ButtonAction::shape);
  EXPECT_EQ(find_button(b, BTN_NORTH)->action, ButtonAction::grow);
  EXPECT_EQ(find_button(b, BTN_WEST)->action, ButtonAction::shrink);
  EXPECT_EQ(find_button(b, BTN_THUMBL)->tool, 0);
  EXPECT_EQ(find_button(b, BTN_THUMBL)->action, ButtonAction::grab);
  EXPECT_EQ(find_button(b, BTN_TL)->action, ButtonAction::depth_minus);
  EXPECT_EQ(find_button(b, BTN_TL)->tool, 0);
  EXPECT_EQ(find_button(b, BTN_TR)->tool, 1);
  EXPECT_TRUE(b.drives(0));
  EXPECT_TRUE(b.drives(1));
  EXPECT_FALSE(b.drives(2));
  // Calibration comes from absinfo.
  EXPECT_EQ(find_axis(b, ABS_X)->calibration.minimum, -32768);
  EXPECT_EQ(find_axis(b, ABS_X)->calibration.flat, 128);
}

TEST(DefaultMapping, OneToolOnAPadGetsEveryHandsButtons) {
  const DeviceInfo pad = testing::gamepad();
  const DeviceBinding b = make_binding(pad, default_mapping(pad), {{3, Stick::left}});
  EXPECT_EQ(find_axis(b, ABS_RX), nullptr) << "the other stick drives nothing";
  ASSERT_NE(find_button(b, BTN_SOUTH), nullptr);
  EXPECT_EQ(find_button(b, BTN_SOUTH)->tool, 3);
  EXPECT_EQ(find_button(b, BTN_SOUTH)->action, ButtonAction::grab);
  EXPECT_EQ(find_button(b, BTN_THUMBL)->tool, 3);
  EXPECT_EQ(find_button(b, BTN_TR), nullptr) << "the other shoulder does not pull depth";
  EXPECT_EQ(b.tool_mask, 1u << 3);
}

TEST(DefaultMapping, JoystickDepthFromTwistAndClassicButtons) {
  const DeviceInfo stick = testing::flight_stick();
  const DeviceBinding b = make_binding(stick, default_mapping(stick), {{0, Stick::main}});
  EXPECT_EQ(find_axis(b, ABS_X)->component, 0);
  EXPECT_EQ(find_axis(b, ABS_RZ)->component, 2);
  EXPECT_FALSE(find_axis(b, ABS_RZ)->calibration.unipolar);
  EXPECT_EQ(find_axis(b, ABS_THROTTLE), nullptr);
  EXPECT_EQ(find_button(b, BTN_TRIGGER)->action, ButtonAction::grab);
  EXPECT_EQ(find_button(b, BTN_THUMB)->action, ButtonAction::shape);
  EXPECT_EQ(find_button(b, BTN_THUMB2)->action, ButtonAction::grow);
  EXPECT_EQ(find_button(b, BTN_TOP)->action, ButtonAction::shrink);

  DeviceInfo throttle_only = stick;
  throttle_only.axes.erase(std::remove_if(throttle_only.axes.begin(), throttle_only.axes.end(),
                                          [](auto& a) { return a.code == ABS_RZ; }),
                           throttle_only.axes.end());
  const DeviceBinding t = make_binding(throttle_only, default_mapping(throttle_only), {{0, Stick::main}});
  EXPECT_EQ(find_axis(t, ABS_THROTTLE)->component, 2);
}

TEST(DefaultMapping, StickPlaneTellsTheHapticsWhichAxesMoveTheTool) {
  const DeviceInfo pad = testing::gamepad();
  const DeviceBinding b = make_binding(pad, default_mapping(pad), {{0, Stick::left}, {1, Stick::right}});
  const StickPlane p1 = stick_plane(b, 1);
  ASSERT_TRUE(p1.valid);
  EXPECT_EQ(p1.x_code, ABS_RX);
  EXPECT_EQ(p1.y_code, ABS_RY);
  EXPECT_EQ(p1.y_scale, -1.0f);
  EXPECT_FALSE(stick_plane(b, 5).valid);
}

TEST(Overrides, ParsedAndAppliedByVendorProductAndName) {
  const MappingConfig cfg = parse(R"(
[input]
dead_zone = 0.1

[[device]]
vendor = 0x046d
product = 0xc21d
left_x = "-ABS_RX"
left_grab = "BTN_START"
left_depth = "none"

[[device]]
name = "Flight"
dead_zone = 0.25
main_depth = "ABS_THROTTLE+"
)");
  EXPECT_FLOAT_EQ(cfg.dead_zone, 0.1f);
  ASSERT_EQ(cfg.overrides.size(), 2u);
  EXPECT_EQ(cfg.overrides[0].line, 5u);

  const DeviceInfo pad = testing::gamepad();
  const DeviceMapping m = resolve_mapping(pad, cfg);
  EXPECT_FLOAT_EQ(m.dead_zone, 0.1f);
  ASSERT_TRUE(m[Stick::left][Role::x].has_value());
  EXPECT_EQ(m[Stick::left][Role::x]->code, ABS_RX);
  EXPECT_TRUE(m[Stick::left][Role::x]->invert);
  EXPECT_FALSE(m[Stick::left][Role::depth].has_value());
  const DeviceBinding b = make_binding(pad, m, {{0, Stick::left}});
  EXPECT_EQ(find_button(b, BTN_START)->action, ButtonAction::grab);
  EXPECT_EQ(find_axis(b, ABS_RX)->scale, -1.0f);
  EXPECT_EQ(find_axis(b, ABS_Z), nullptr);
  EXPECT_FLOAT_EQ(find_axis(b, ABS_RX)->calibration.dead_zone, 0.1f);

  const DeviceInfo stick = testing::flight_stick();
  const DeviceMapping s = resolve_mapping(stick, cfg);
  EXPECT_FLOAT_EQ(s.dead_zone, 0.25f);
  EXPECT_EQ(s[Stick::main][Role::depth]->code, ABS_THROTTLE);
  EXPECT_TRUE(s[Stick::main][Role::depth]->unipolar);

  DeviceInfo other_pad = pad;
  other_pad.product = 0x1234;
  EXPECT_FALSE(resolve_mapping(other_pad, cfg)[Stick::left][Role::x]->invert);
}

TEST(Overrides, KindForcesTheDefaults) {
  const MappingConfig cfg = parse("[[device]]\nname = \"Flight\"\nkind = \"gamepad\"\n");
  const DeviceMapping m = resolve_mapping(testing::flight_stick(), cfg);
  EXPECT_TRUE(m[Stick::right][Role::x].has_value());
}

TEST(Overrides, NumbersAreCodes) {
  const MappingConfig cfg = parse("[[device]]\nname = \"Pad\"\nright_grab = 0x130\n");
  EXPECT_EQ(cfg.overrides[0].entries[0].control->code, BTN_SOUTH);
}

TEST(Overrides, EmptyConfigIsDefaults) {
  const MappingConfig cfg = parse("");
  EXPECT_TRUE(cfg.overrides.empty());
  EXPECT_FLOAT_EQ(cfg.dead_zone, MappingConfig{}.dead_zone);
}

TEST(Overrides, ErrorsNameFileLineAndKey) {
  EXPECT_EQ(parse_error("[[device]]\nname = \"x\"\nleft_wobble = \"ABS_X\"\n").rfind("test.conf:3: unknown key 'left_wobble'", 0), 0u)
      << parse_error("[[device]]\nname = \"x\"\nleft_wobble = \"ABS_X\"\n");
  EXPECT_NE(parse_error("[[device]]\nname = \"x\"\nleft_x = \"ABS_NOPE\"\n").find("test.conf:3: left_x = \"ABS_NOPE\": unknown axis"), std::string::npos);
  EXPECT_NE(parse_error("[[device]]\nname = \"x\"\nleft_grab = \"ABS_X\"\n").find("unknown button"), std::string::npos);
  EXPECT_NE(parse_error("[[device]]\ndead_zone = 0.1\n").find("needs vendor, product or name"), std::string::npos);
  EXPECT_NE(parse_error("[[device]]\nvendor = 70000\n").find("test.conf:2: vendor must be"), std::string::npos);
  EXPECT_NE(parse_error("[[device]]\nname = \"x\"\ndead_zone = 1.5\n").find("dead_zone must be"), std::string::npos);
  EXPECT_NE(parse_error("[input]\ndead_zone = \"big\"\n").find("test.conf:2: dead_zone"), std::string::npos);
  EXPECT_NE(parse_error("[[device]]\nname = \"x\"\nkind = \"wheel\"\n").find("kind must be"), std::string::npos);
  EXPECT_NE(parse_error("device = 3\n").find("array of tables"), std::string::npos);
  EXPECT_NE(parse_error("[[device]]\nname = \"x\"\nleft_x = true\n").find("left_x must be"), std::string::npos);
}

TEST(ToolRouter, SlotRoutesAndNameRoutes) {
  ToolRouter router({{0, "", Stick::left}, {0, "", Stick::right}, {0, "Flight", Stick::main}});
  const MappingConfig cfg;
  const DeviceBinding pad = router.attach(0, testing::gamepad(), cfg);
  EXPECT_TRUE(pad.drives(0));
  EXPECT_TRUE(pad.drives(1));
  EXPECT_FALSE(pad.drives(2));
  const DeviceBinding stick = router.attach(1, testing::flight_stick(), cfg);
  EXPECT_EQ(stick.tool_mask, 1u << 2);
  // A second matching device does not steal the claimed tool...
  const DeviceBinding stick2 = router.attach(2, testing::flight_stick(), cfg);
  EXPECT_EQ(stick2.tool_mask, 0u);
  // ...until the first goes away.
  router.detach(1);
  EXPECT_EQ(router.attach(2, testing::flight_stick(), cfg).tool_mask, 1u << 2);
}

TEST(ToolRouter, RightStickOnAOneStickDeviceFallsBackWithAWarning) {
  ToolRouter router({{0, "", Stick::right}});
  const DeviceBinding b = router.attach(0, testing::flight_stick(), MappingConfig{});
  EXPECT_TRUE(b.drives(0));
  ASSERT_FALSE(router.warnings().empty());
  EXPECT_NE(router.warnings()[0].find("right stick"), std::string::npos);
}

TEST(EventCodes, NamesBothWays) {
  EXPECT_EQ(event_code(EV_ABS, "ABS_RY"), ABS_RY);
  EXPECT_EQ(event_code(EV_KEY, "BTN_SOUTH"), BTN_SOUTH);
  EXPECT_FALSE(event_code(EV_ABS, "BTN_SOUTH").has_value());
  EXPECT_EQ(event_code_name(EV_ABS, ABS_X), "ABS_X");
}

}  // namespace
}  // namespace sculpt::input

namespace sculpt::input {
namespace {

DeviceInfo pad_with_dpad() {
  DeviceInfo pad = testing::gamepad();
  pad.buttons.insert(pad.buttons.end(), {BTN_DPAD_UP, BTN_DPAD_DOWN, BTN_DPAD_LEFT, BTN_DPAD_RIGHT});
  std::sort(pad.buttons.begin(), pad.buttons.end());
  return pad;
}

InputMessage press(std::uint16_t code, std::int32_t value) {
  InputFrame f;
  f.push({EV_KEY, code, value});
  f.push({EV_SYN, SYN_REPORT, 0});
  return InputMessage::of_frame(f);
}

TEST(DefaultMapping, TheDpadsLeftAndRightUndoAndRedo) {
  const DeviceInfo pad = pad_with_dpad();
  const DeviceBinding b = make_binding(pad, default_mapping(pad), {{0, Stick::left}, {1, Stick::right}});
  ASSERT_NE(find_button(b, BTN_DPAD_LEFT), nullptr);
  EXPECT_EQ(find_button(b, BTN_DPAD_LEFT)->action, ButtonAction::undo);
  ASSERT_NE(find_button(b, BTN_DPAD_RIGHT), nullptr);
  EXPECT_EQ(find_button(b, BTN_DPAD_RIGHT)->action, ButtonAction::redo);
  const MappingConfig cfg = parse("[[device]]\nname = \"Test\"\nleft_undo = \"BTN_START\"\nright_undo = \"BTN_START\"\n");
  const DeviceBinding o = make_binding(pad, resolve_mapping(pad, cfg), {{0, Stick::left}, {1, Stick::right}});
  ASSERT_NE(find_button(o, BTN_START), nullptr);
  EXPECT_EQ(find_button(o, BTN_START)->action, ButtonAction::undo);
}

TEST(ControlMapper, CountsUndoAndRedoPressesOfAnyTool) {
  const DeviceInfo pad = pad_with_dpad();
  ControlMapper m(2);
  m.apply(InputMessage::attach(0, make_binding(pad, default_mapping(pad), {{0, Stick::left}, {1, Stick::right}})));
  m.apply(press(BTN_DPAD_LEFT, 1));
  m.apply(press(BTN_DPAD_LEFT, 2));  // autorepeat: not a press
  m.apply(press(BTN_DPAD_LEFT, 0));
  m.apply(press(BTN_DPAD_LEFT, 1));
  m.apply(press(BTN_DPAD_RIGHT, 1));
  EXPECT_EQ(m.undo_presses(), 2u);
  EXPECT_EQ(m.redo_presses(), 1u);
}

TEST(ControlMapper, ItsStateComesBackExactly) {
  const DeviceInfo pad = pad_with_dpad();
  ControlMapper m(2);
  m.apply(InputMessage::attach(3, make_binding(pad, default_mapping(pad), {{0, Stick::left}})));
  InputFrame f;
  f.push({EV_ABS, ABS_X, 20000});
  f.push({EV_KEY, BTN_THUMBL, 1});
  m.apply(InputMessage::of_frame([&] {
    f.slot = 3;
    return f;
  }()));
  m.apply(press(BTN_DPAD_LEFT, 1));
  ControlMapper back(2);
  back.restore_state(m.state());
  EXPECT_EQ(back.state(), m.state());
  EXPECT_TRUE(back.attached(3));
  EXPECT_EQ(back.controls()[0].stick, m.controls()[0].stick);
  EXPECT_TRUE(back.controls()[0].grab);
  ControlMapper other(3);
  EXPECT_THROW(other.restore_state(m.state()), std::invalid_argument);
  const std::vector<std::byte> whole = m.state();
  const std::vector<std::byte> truncated(whole.begin(), whole.end() - 1);
  EXPECT_THROW(back.restore_state(truncated), std::invalid_argument);
}

}  // namespace
}  // namespace sculpt::input
