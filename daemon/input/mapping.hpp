// Which axis and button of a device drives which tool, and how.
//
// Defaults (docs/input.md has the table):
//   gamepad (two sticks): left stick → the tool on stick "left", right stick →
//     the tool on stick "right"; depth from the triggers (ABS_Z / ABS_RZ, in)
//     and shoulder buttons (BTN_TL / BTN_TR, out); buttons per hand.
//   joystick (one stick): X/Y, depth from twist (ABS_RZ), else ABS_Z, else the
//     throttle; trigger grabs, thumb buttons switch shape and size.
// A device with one tool bound gets every button of the pad for that tool.
// Per-device overrides come from the daemon config's [[device]] tables.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "input/device_info.hpp"
#include "input/input_message.hpp"

#include <toml++/toml.h>

namespace sculpt::input {

// Which stick of a device drives a tool (as scene files say it).
enum class Stick : std::uint8_t { left, right, main };

// What a control does for the tool of a stick.
// grab..redo in ButtonAction's order.
enum class Role : std::uint8_t { x, y, depth, grab, shape, grow, shrink, depth_plus, depth_minus, undo, redo };
inline constexpr std::size_t kRoleCount = 11;

std::string_view to_string(Stick stick);
std::string_view to_string(Role role);

// One control: an ABS_* code (roles x, y, depth) or a BTN_*/KEY_* code
// (the others). `invert` flips an axis.
struct ControlCode {
  std::uint16_t code = 0;
  bool invert = false;
  bool unipolar = false;  // a trigger: reads 0..1
  bool operator==(const ControlCode&) const = default;
};

// Per stick, per role: the control, or none.
struct StickMapping {
  std::array<std::optional<ControlCode>, kRoleCount> roles{};
  std::optional<ControlCode>& operator[](Role r) { return roles[static_cast<std::size_t>(r)]; }
  const std::optional<ControlCode>& operator[](Role r) const { return roles[static_cast<std::size_t>(r)]; }
};

struct DeviceMapping {
  std::array<StickMapping, 3> sticks{};  // indexed by Stick
  float dead_zone = 0.0f;
  StickMapping& operator[](Stick s) { return sticks[static_cast<std::size_t>(s)]; }
  const StickMapping& operator[](Stick s) const { return sticks[static_cast<std::size_t>(s)]; }
};

// A [[device]] table: matched by vendor/product (when given) and a name
// substring (when given); later tables win over earlier ones.
struct DeviceOverride {
  std::optional<std::uint16_t> vendor;
  std::optional<std::uint16_t> product;
  std::string name_contains;
  std::optional<DeviceKind> kind;      // force the classification
  std::optional<float> dead_zone;
  struct Entry {
    Stick stick;
    Role role;
    std::optional<ControlCode> control;    // nullopt: unbind
  };
  std::vector<Entry> entries;
  unsigned line = 0;

  bool matches(const DeviceInfo& info) const;
};

struct MappingConfig {
  float dead_zone = 0.05f;             // on top of the kernel's flat
  std::vector<DeviceOverride> overrides;
};

class MappingError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Reads the daemon config's mapping keys: `[input] dead_zone = 0.05` and
// every `[[device]]` table:
//   [[device]]
//   vendor = 0x046d            # optional
//   product = 0xc21d           # optional
//   name = "F310"              # optional, substring of the device name
//   kind = "gamepad"           # optional: gamepad | joystick
//   dead_zone = 0.1            # optional
//   left_x = "ABS_X"           # <stick>_<role> = "CODE", "-CODE" (inverted), "none", or a number
//   right_grab = "BTN_TR"
// Throws MappingError naming `file`, the line and the key on anything wrong.
MappingConfig parse_mapping(const toml::table& config, const std::filesystem::path& file = "config");

// The default mapping for a device of its kind, before overrides.
DeviceMapping default_mapping(const DeviceInfo& info);
// Defaults, then every matching override in order.
DeviceMapping resolve_mapping(const DeviceInfo& info, const MappingConfig& config);

// "ABS_X" → code (EV_ABS), "BTN_SOUTH"/"KEY_A" → code (EV_KEY); nullopt when unknown.
std::optional<std::uint16_t> event_code(std::uint16_t type, std::string_view name);
std::string event_code_name(std::uint16_t type, std::uint16_t code);

// Where a tool takes its input from: the scene's tool table.
struct ToolRoute {
  int device = 0;             // device slot (joysticks in plug-in order)...
  std::string device_name;    // ...or, when not empty, the first device whose name contains this
  Stick stick = Stick::left;
};

// Binds devices to tools on the io thread: remembers which tool is driven by
// which slot (name routes claim the first matching device) and builds the POD
// DeviceBinding the simulation thread applies.
class ToolRouter {
 public:
  explicit ToolRouter(std::vector<ToolRoute> routes = {});

  const std::vector<ToolRoute>& routes() const { return routes_; }
  void set_routes(std::vector<ToolRoute> routes);

  DeviceBinding attach(std::uint8_t slot, const DeviceInfo& info, const MappingConfig& config);
  void detach(std::uint8_t slot);
  // Why the last attach left a tool or control unbound ("tool 1 wants the right stick, ...").
  const std::vector<std::string>& warnings() const { return warnings_; }

 private:
  std::vector<ToolRoute> routes_;
  std::array<int, sim::kMaxTools> claimed_by_{};  // slot + 1 that drives tool t, 0 = none
  std::vector<std::string> warnings_;
};

// Builds the binding of one device to the given tools (tool index → stick),
// with calibration from the device's absinfo. Pure; ToolRouter calls it.
DeviceBinding make_binding(const DeviceInfo& info, const DeviceMapping& mapping,
                           const std::vector<std::pair<std::uint8_t, Stick>>& tools,
                           std::vector<std::string>* warnings = nullptr);

}  // namespace sculpt::input
