#include "input/mapping.hpp"

#include <libevdev/libevdev.h>
#include <linux/input.h>

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace sculpt::input {
namespace {

constexpr std::array<std::string_view, 3> kStickNames{"left", "right", "main"};
constexpr std::array<std::string_view, kRoleCount> kRoleNames{
    "x", "y", "depth", "grab", "shape", "grow", "shrink", "depth_plus", "depth_minus", "undo", "redo"};
static_assert(static_cast<int>(Role::redo) - static_cast<int>(Role::grab) == static_cast<int>(ButtonAction::redo),
              "a button role's ButtonAction is its offset from grab");

bool is_axis_role(Role r) { return r == Role::x || r == Role::y || r == Role::depth; }

ControlCode axis(std::uint16_t code, bool invert = false, bool unipolar = false) { return {code, invert, unipolar}; }
ControlCode key(std::uint16_t code) { return {code, false, false}; }

void set(StickMapping& s, Role r, ControlCode c) { s[r] = c; }

StickMapping gamepad_stick(bool left) {
  StickMapping s;
  set(s, Role::x, axis(left ? ABS_X : ABS_RX));
  // Stick "up" reads negative on evdev; up should move the tool up/forward.
  set(s, Role::y, axis(left ? ABS_Y : ABS_RY, true));
  set(s, Role::depth, axis(left ? ABS_Z : ABS_RZ, false, true));  // trigger: in
  set(s, Role::depth_minus, key(left ? BTN_TL : BTN_TR));           // shoulder: out
  if (left) {
    set(s, Role::grab, key(BTN_THUMBL));
    set(s, Role::shape, key(BTN_SELECT));
    set(s, Role::grow, key(BTN_DPAD_UP));
    set(s, Role::shrink, key(BTN_DPAD_DOWN));
  } else {
    set(s, Role::grab, key(BTN_SOUTH));
    set(s, Role::shape, key(BTN_EAST));
    set(s, Role::grow, key(BTN_NORTH));
    set(s, Role::shrink, key(BTN_WEST));
  }
  // Either hand's: the D-pad's free pair, back and forth through the history.
  set(s, Role::undo, key(BTN_DPAD_LEFT));
  set(s, Role::redo, key(BTN_DPAD_RIGHT));
  return s;
}

StickMapping joystick_stick(const DeviceInfo& info) {
  StickMapping s;
  set(s, Role::x, axis(ABS_X));
  set(s, Role::y, axis(ABS_Y, true));
  // Depth: the twist if there is one, else Z, else the throttle lever.
  for (std::uint16_t code : {std::uint16_t(ABS_RZ), std::uint16_t(ABS_Z), std::uint16_t(ABS_THROTTLE)}) {
    if (info.axis(code)) {
      set(s, Role::depth, axis(code));
      break;
    }
  }
  const bool classic = info.has_button(BTN_TRIGGER) || !info.has_button(BTN_SOUTH);
  set(s, Role::grab, key(classic ? BTN_TRIGGER : BTN_SOUTH));
  set(s, Role::shape, key(classic ? BTN_THUMB : BTN_EAST));
  set(s, Role::grow, key(classic ? BTN_THUMB2 : BTN_NORTH));
  set(s, Role::shrink, key(classic ? BTN_TOP : BTN_WEST));
  set(s, Role::undo, key(classic ? BTN_BASE : BTN_SELECT));
  set(s, Role::redo, key(classic ? BTN_BASE2 : BTN_START));
  return s;
}

std::string where(const std::filesystem::path& file, const toml::node& node) {
  return fmt::format("{}:{}", file.string(), node.source().begin.line);
}

std::optional<ControlCode> parse_control(const toml::node& node, Role role, const std::string& at,
                                     const std::string& key_name) {
  const std::uint16_t type = is_axis_role(role) ? EV_ABS : EV_KEY;
  if (auto n = node.value_exact<std::int64_t>()) {
    if (*n < 0 || *n > (type == EV_ABS ? ABS_MAX : KEY_MAX))
      throw MappingError(fmt::format("{}: {} = {}: not a valid {} code", at, key_name, *n,
                                     type == EV_ABS ? "axis" : "button"));
    return ControlCode{static_cast<std::uint16_t>(*n), false, false};
  }
  auto s = node.value_exact<std::string>();
  if (!s)
    throw MappingError(fmt::format("{}: {} must be a code name like \"{}\", \"none\" or a number", at, key_name,
                                   type == EV_ABS ? "ABS_X" : "BTN_SOUTH"));
  std::string_view text = *s;
  if (text == "none" || text.empty()) return std::nullopt;
  ControlCode c;
  if (type == EV_ABS && text.front() == '-') c.invert = true, text.remove_prefix(1);
  if (type == EV_ABS && !text.empty() && text.back() == '+') c.unipolar = true, text.remove_suffix(1);
  auto code = event_code(type, text);
  if (!code)
    throw MappingError(fmt::format("{}: {} = \"{}\": unknown {} name{}", at, key_name, *s,
                                   type == EV_ABS ? "axis (ABS_*)" : "button (BTN_*/KEY_*)",
                                   type == EV_ABS ? " (\"-ABS_Y\" inverts, \"ABS_Z+\" reads a trigger 0..1)" : ""));
  c.code = *code;
  return c;
}

float parse_dead_zone(const toml::node& node, const std::string& at) {
  auto v = node.value<double>();
  if (!v || !std::isfinite(*v) || *v < 0.0 || *v >= 0.95)
    throw MappingError(fmt::format("{}: dead_zone must be a number in [0, 0.95)", at));
  return static_cast<float>(*v);
}

std::uint16_t parse_id(const toml::node& node, const std::string& at, std::string_view key_name) {
  auto v = node.value_exact<std::int64_t>();
  if (!v || *v < 0 || *v > 0xffff)
    throw MappingError(fmt::format("{}: {} must be an integer 0..0xffff (e.g. 0x046d)", at, key_name));
  return static_cast<std::uint16_t>(*v);
}

DeviceOverride parse_override(const toml::table& t, const std::filesystem::path& file) {
  DeviceOverride o;
  o.line = t.source().begin.line;
  for (const auto& [k, node] : t) {
    const std::string key_name(k.str());
    const std::string at = where(file, node);
    if (key_name == "vendor") o.vendor = parse_id(node, at, key_name);
    else if (key_name == "product") o.product = parse_id(node, at, key_name);
    else if (key_name == "name") {
      auto s = node.value_exact<std::string>();
      if (!s || s->empty()) throw MappingError(fmt::format("{}: name must be a non-empty string", at));
      o.name_contains = *s;
    } else if (key_name == "kind") {
      auto s = node.value_exact<std::string>();
      if (s && *s == "gamepad") o.kind = DeviceKind::gamepad;
      else if (s && *s == "joystick") o.kind = DeviceKind::joystick;
      else throw MappingError(fmt::format("{}: kind must be \"gamepad\" or \"joystick\"", at));
    } else if (key_name == "dead_zone") {
      o.dead_zone = parse_dead_zone(node, at);
    } else {
      // <stick>_<role>
      bool found = false;
      for (std::size_t s = 0; s < kStickNames.size() && !found; ++s) {
        const std::string prefix = std::string(kStickNames[s]) + "_";
        if (key_name.rfind(prefix, 0) != 0) continue;
        const std::string_view role_name = std::string_view(key_name).substr(prefix.size());
        for (std::size_t r = 0; r < kRoleCount; ++r) {
          if (kRoleNames[r] != role_name) continue;
          const auto role = static_cast<Role>(r);
          o.entries.push_back({static_cast<Stick>(s), role, parse_control(node, role, at, key_name)});
          found = true;
          break;
        }
      }
      if (!found)
        throw MappingError(fmt::format(
            "{}: unknown key '{}' in [[device]] (expected vendor, product, name, kind, dead_zone or "
            "<left|right|main>_<x|y|depth|grab|shape|grow|shrink|depth_plus|depth_minus>)",
            at, key_name));
    }
  }
  if (!o.vendor && !o.product && o.name_contains.empty())
    throw MappingError(fmt::format("{}:{}: a [[device]] table needs vendor, product or name to match on",
                                   file.string(), o.line));
  return o;
}

}  // namespace

std::string_view to_string(Stick stick) { return kStickNames[static_cast<std::size_t>(stick)]; }
std::string_view to_string(Role role) { return kRoleNames[static_cast<std::size_t>(role)]; }

bool DeviceOverride::matches(const DeviceInfo& info) const {
  if (vendor && *vendor != info.vendor) return false;
  if (product && *product != info.product) return false;
  if (!name_contains.empty() && info.name.find(name_contains) == std::string::npos) return false;
  return true;
}

MappingConfig parse_mapping(const toml::table& config, const std::filesystem::path& file) {
  MappingConfig m;
  if (const toml::node* input = config.get("input")) {
    if (const toml::table* t = input->as_table()) {
      if (const toml::node* dz = t->get("dead_zone")) m.dead_zone = parse_dead_zone(*dz, where(file, *dz));
    }
  }
  if (const toml::node* devices = config.get("device")) {
    const toml::array* arr = devices->as_array();
    if (!arr) throw MappingError(fmt::format("{}: 'device' must be an array of tables ([[device]])", where(file, *devices)));
    for (const toml::node& n : *arr) {
      const toml::table* t = n.as_table();
      if (!t) throw MappingError(fmt::format("{}: every [[device]] entry must be a table", where(file, n)));
      m.overrides.push_back(parse_override(*t, file));
    }
  }
  return m;
}

DeviceMapping default_mapping(const DeviceInfo& info) {
  DeviceMapping m;
  if (info.kind == DeviceKind::gamepad) {
    m[Stick::left] = gamepad_stick(true);
    m[Stick::right] = gamepad_stick(false);
    m[Stick::main] = m[Stick::left];
  } else if (info.kind == DeviceKind::joystick) {
    m[Stick::main] = joystick_stick(info);
    m[Stick::left] = m[Stick::main];
  }
  return m;
}

DeviceMapping resolve_mapping(const DeviceInfo& info, const MappingConfig& config) {
  DeviceInfo as = info;
  for (const auto& o : config.overrides)
    if (o.kind && o.matches(info)) as.kind = *o.kind;
  DeviceMapping m = default_mapping(as);
  m.dead_zone = config.dead_zone;
  for (const auto& o : config.overrides) {
    if (!o.matches(info)) continue;
    if (o.dead_zone) m.dead_zone = *o.dead_zone;
    for (const auto& e : o.entries) m[e.stick][e.role] = e.control;
  }
  return m;
}

std::optional<std::uint16_t> event_code(std::uint16_t type, std::string_view name) {
  const int code = libevdev_event_code_from_name_n(type, name.data(), name.size());
  if (code < 0) return std::nullopt;
  return static_cast<std::uint16_t>(code);
}

std::string event_code_name(std::uint16_t type, std::uint16_t code) {
  const char* n = libevdev_event_code_get_name(type, code);
  return n ? n : fmt::format("{}:{}", type, code);
}

DeviceBinding make_binding(const DeviceInfo& info, const DeviceMapping& mapping,
                           const std::vector<std::pair<std::uint8_t, Stick>>& tools,
                           std::vector<std::string>* warnings) {
  auto warn = [&](std::string w) {
    if (warnings) warnings->push_back(std::move(w));
  };
  DeviceBinding b;
  auto bound_button = [&](std::uint16_t code) {
    for (std::size_t i = 0; i < b.button_count; ++i)
      if (b.buttons[i].code == code) return true;
    return false;
  };
  auto add_buttons = [&](std::uint8_t tool, const StickMapping& sm, bool all_roles) {
    for (std::size_t r = static_cast<std::size_t>(Role::grab); r < kRoleCount; ++r) {
      const auto role = static_cast<Role>(r);
      if (!all_roles && (role == Role::depth_plus || role == Role::depth_minus)) continue;
      const auto& c = sm[role];
      if (!c || !info.has_button(c->code) || bound_button(c->code)) continue;
      ButtonBinding k;
      k.code = c->code;
      k.tool = tool;
      k.action = static_cast<ButtonAction>(r - static_cast<std::size_t>(Role::grab));
      if (!b.add_button(k)) warn(fmt::format("'{}': more than {} buttons bound, {} ignored", info.name,
                                             kMaxBoundButtons, event_code_name(EV_KEY, c->code)));
    }
  };
  for (const auto& [tool, stick] : tools) {
    if (tool >= sim::kMaxTools) continue;
    const StickMapping& sm = mapping[stick];
    for (Role role : {Role::x, Role::y, Role::depth}) {
      const auto& c = sm[role];
      if (!c) continue;
      const AxisInfo* ax = info.axis(c->code);
      if (!ax) {
        if (role != Role::depth)
          warn(fmt::format("'{}' has no {}: tool {} cannot move along {}", info.name,
                           event_code_name(EV_ABS, c->code), tool, to_string(role)));
        continue;
      }
      AxisBinding a;
      a.code = c->code;
      a.tool = tool;
      a.component = static_cast<std::uint8_t>(role);
      a.scale = c->invert ? -1.0f : 1.0f;
      a.calibration = calibrate(*ax, mapping.dead_zone, c->unipolar);
      if (!b.add_axis(a)) warn(fmt::format("'{}': more than {} axes bound", info.name, kMaxBoundAxes));
    }
    add_buttons(tool, sm, true);
  }
  // One tool on the device: every hand's buttons serve it.
  if (tools.size() == 1 && tools[0].first < sim::kMaxTools) {
    for (const auto& sm : mapping.sticks) add_buttons(tools[0].first, sm, false);
  }
  // A tool is "driven" even when only buttons bind it; make sure the mask says so.
  for (const auto& [tool, stick] : tools)
    if (tool < 32) b.tool_mask |= 1u << tool;
  return b;
}

ToolRouter::ToolRouter(std::vector<ToolRoute> routes) : routes_(std::move(routes)) {}

void ToolRouter::set_routes(std::vector<ToolRoute> routes) {
  routes_ = std::move(routes);
  claimed_by_.fill(0);
}

DeviceBinding ToolRouter::attach(std::uint8_t slot, const DeviceInfo& info, const MappingConfig& config) {
  warnings_.clear();
  const DeviceMapping mapping = resolve_mapping(info, config);
  std::vector<std::pair<std::uint8_t, Stick>> tools;
  const std::size_t n = std::min(routes_.size(), sim::kMaxTools);
  for (std::size_t t = 0; t < n; ++t) {
    const ToolRoute& r = routes_[t];
    bool mine;
    if (!r.device_name.empty())
      mine = info.name.find(r.device_name) != std::string::npos &&
             (claimed_by_[t] == 0 || claimed_by_[t] == slot + 1);
    else
      mine = r.device == slot;
    if (!mine) continue;
    claimed_by_[t] = slot + 1;
    Stick stick = r.stick;
    const bool pad = mapping[Stick::right][Role::x].has_value();
    if (stick == Stick::right && !pad) {
      warnings_.push_back(fmt::format("tool {} wants the right stick but '{}' has one stick: using it", t,
                                      info.name));
      stick = Stick::main;
    }
    tools.emplace_back(static_cast<std::uint8_t>(t), stick);
  }
  return make_binding(info, mapping, tools, &warnings_);
}

void ToolRouter::detach(std::uint8_t slot) {
  for (auto& c : claimed_by_)
    if (c == slot + 1) c = 0;
}

}  // namespace sculpt::input
