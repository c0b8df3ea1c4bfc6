#include "input/recording.hpp"

#include <libevdev/libevdev.h>
#include <linux/input.h>

#include <algorithm>
#include <charconv>
#include <climits>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "files/regular_file.hpp"

namespace sculpt::input {
namespace {

using nlohmann::json;

std::string code_name(std::uint16_t type, std::uint16_t code) {
  const char* n = libevdev_event_code_get_name(type, code);
  return n ? std::string(n) : std::to_string(code);
}

[[noreturn]] void fail(const std::string& where, const std::string& what) {
  throw RecordingError(fmt::format("{}: {}", where, what));
}

// An integer JSON value as int64: nlohmann reads 18446744073709551615 as an
// unsigned number, which get<int64_t>() would turn into -1; such values are
// out of every range here, so they become INT64_MAX (and fail the check).
std::int64_t int_value(const json& j) {
  if (j.is_number_unsigned() && j.get<std::uint64_t>() > static_cast<std::uint64_t>(INT64_MAX)) return INT64_MAX;
  return j.get<std::int64_t>();
}

// A code given by name ("ABS_X") or number.
std::uint16_t parse_code(const json& j, std::uint16_t type, const std::string& where, const std::string& field) {
  if (j.is_number_integer()) {
    const auto v = int_value(j);
    if (v < 0 || v > 0x2ff) fail(where, fmt::format("{}: code {} out of range (0..0x2ff)", field, j.dump()));
    return static_cast<std::uint16_t>(v);
  }
  if (j.is_string()) {
    const auto s = j.get<std::string>();
    const int c = libevdev_event_code_from_name(type, s.c_str());
    if (c < 0) fail(where, fmt::format("{}: unknown event code name '{}'", field, s));
    return static_cast<std::uint16_t>(c);
  }
  fail(where, fmt::format("{}: expected a code name or number", field));
}

template <class T>
T get_int(const json& obj, const char* key, const std::string& where, const std::string& ctx, T fallback,
          bool required) {
  auto it = obj.find(key);
  if (it == obj.end()) {
    if (required) fail(where, fmt::format("{}: missing field '{}'", ctx, key));
    return fallback;
  }
  if (!it->is_number_integer()) fail(where, fmt::format("{}: field '{}' must be an integer", ctx, key));
  const auto v = int_value(*it);
  if (v < static_cast<std::int64_t>(std::numeric_limits<T>::min()) ||
      v > static_cast<std::int64_t>(std::numeric_limits<T>::max()))
    fail(where, fmt::format("{}: field '{}' = {} is out of range ({}..{})", ctx, key, it->dump(),
                            +std::numeric_limits<T>::min(), +std::numeric_limits<T>::max()));
  return static_cast<T>(v);
}

std::string get_str(const json& obj, const char* key, const std::string& where, const std::string& ctx,
                    bool required) {
  auto it = obj.find(key);
  if (it == obj.end()) {
    if (required) fail(where, fmt::format("{}: missing field '{}'", ctx, key));
    return {};
  }
  if (!it->is_string()) fail(where, fmt::format("{}: field '{}' must be a string", ctx, key));
  return it->get<std::string>();
}

json device_to_json(const DeviceInfo& d) {
  json axes = json::array();
  for (const auto& a : d.axes)
    axes.push_back({{"code", code_name(EV_ABS, a.code)}, {"value", a.value}, {"min", a.minimum},
                    {"max", a.maximum}, {"fuzz", a.fuzz}, {"flat", a.flat}, {"resolution", a.resolution}});
  json buttons = json::array();
  for (auto b : d.buttons) buttons.push_back(code_name(EV_KEY, b));
  json ff = json::array();
  for (auto f : d.ff) ff.push_back(code_name(EV_FF, f));
  return {{"name", d.name},   {"bustype", d.bustype},  {"vendor", d.vendor},
          {"product", d.product}, {"version", d.version}, {"phys", d.phys},
          {"uniq", d.uniq},   {"kind", std::string(to_string(d.kind))},
          {"axes", axes},     {"buttons", buttons},    {"ff", ff},
          {"ff_effects_max", d.ff_effects_max}, {"msc_timestamp", d.has_msc_timestamp}};
}

DeviceInfo device_from_json(const json& j, const std::string& where, std::size_t index) {
  const std::string ctx = fmt::format("devices[{}]", index);
  if (!j.is_object()) fail(where, ctx + ": must be an object");
  DeviceInfo d;
  d.name = get_str(j, "name", where, ctx, true);
  d.bustype = get_int<std::uint16_t>(j, "bustype", where, ctx, 0, false);
  d.vendor = get_int<std::uint16_t>(j, "vendor", where, ctx, 0, true);
  d.product = get_int<std::uint16_t>(j, "product", where, ctx, 0, true);
  d.version = get_int<std::uint16_t>(j, "version", where, ctx, 0, false);
  d.phys = get_str(j, "phys", where, ctx, false);
  d.uniq = get_str(j, "uniq", where, ctx, false);
  d.ff_effects_max = get_int<int>(j, "ff_effects_max", where, ctx, 0, false);
  if (auto it = j.find("msc_timestamp"); it != j.end()) {
    if (!it->is_boolean()) fail(where, ctx + ": field 'msc_timestamp' must be true or false");
    d.has_msc_timestamp = it->get<bool>();
  }
  if (auto it = j.find("axes"); it != j.end()) {
    if (!it->is_array()) fail(where, ctx + ": field 'axes' must be an array");
    for (std::size_t i = 0; i < it->size(); ++i) {
      const json& a = (*it)[i];
      const std::string actx = fmt::format("{}.axes[{}]", ctx, i);
      if (!a.is_object()) fail(where, actx + ": must be an object");
      if (!a.contains("code")) fail(where, actx + ": missing field 'code'");
      AxisInfo ax;
      ax.code = parse_code(a["code"], EV_ABS, where, actx + ".code");
      ax.value = get_int<std::int32_t>(a, "value", where, actx, 0, false);
      ax.minimum = get_int<std::int32_t>(a, "min", where, actx, 0, true);
      ax.maximum = get_int<std::int32_t>(a, "max", where, actx, 0, true);
      ax.fuzz = get_int<std::int32_t>(a, "fuzz", where, actx, 0, false);
      ax.flat = get_int<std::int32_t>(a, "flat", where, actx, 0, false);
      ax.resolution = get_int<std::int32_t>(a, "resolution", where, actx, 0, false);
      if (ax.maximum < ax.minimum) fail(where, fmt::format("{}: max {} < min {}", actx, ax.maximum, ax.minimum));
      d.axes.push_back(ax);
    }
  }
  auto codes = [&](const char* key, std::uint16_t type, std::vector<std::uint16_t>& out) {
    auto it = j.find(key);
    if (it == j.end()) return;
    if (!it->is_array()) fail(where, fmt::format("{}: field '{}' must be an array", ctx, key));
    for (std::size_t i = 0; i < it->size(); ++i)
      out.push_back(parse_code((*it)[i], type, where, fmt::format("{}.{}[{}]", ctx, key, i)));
  };
  codes("buttons", EV_KEY, d.buttons);
  codes("ff", EV_FF, d.ff);
  std::sort(d.axes.begin(), d.axes.end(), [](auto& a, auto& b) { return a.code < b.code; });
  std::sort(d.buttons.begin(), d.buttons.end());
  std::sort(d.ff.begin(), d.ff.end());
  const std::string kind = get_str(j, "kind", where, ctx, false);
  if (kind == "gamepad") d.kind = DeviceKind::gamepad;
  else if (kind == "joystick") d.kind = DeviceKind::joystick;
  else if (kind.empty() || kind == "other") d.kind = classify_capabilities(d);
  else fail(where, fmt::format("{}: kind '{}' is not gamepad, joystick or other", ctx, kind));
  if (!d.ff.empty() && d.ff_effects_max <= 0)
    fail(where, ctx + ": has FF bits but ff_effects_max is not > 0");
  return d;
}

}  // namespace

std::string header_to_json(const RecordingHeader& h) {
  json devices = json::array();
  for (const auto& d : h.devices) devices.push_back(device_to_json(d));
  json j = {{"format", kRecordingFormat}, {"version", h.version}, {"devices", devices}};
  if (!h.description.empty()) j["description"] = h.description;
  return j.dump();
}

RecordingHeader header_from_json(std::string_view line, const std::string& where) {
  json j;
  try {
    j = json::parse(line);
  } catch (const json::parse_error& e) {
    fail(where, fmt::format("the header is not valid JSON ({})", e.what()));
  }
  if (!j.is_object()) fail(where, "the header must be a JSON object");
  if (get_str(j, "format", where, "header", true) != kRecordingFormat)
    fail(where, fmt::format("not a recording: 'format' is not \"{}\"", kRecordingFormat));
  RecordingHeader h;
  h.version = get_int<int>(j, "version", where, "header", 0, true);
  if (h.version != kRecordingVersion)
    fail(where, fmt::format("recording format version {} is not supported (this build reads version {})",
                            h.version, kRecordingVersion));
  h.description = get_str(j, "description", where, "header", false);
  auto it = j.find("devices");
  if (it == j.end() || !it->is_array()) fail(where, "header: 'devices' must be an array");
  if (it->empty()) fail(where, "header: 'devices' is empty: a recording needs at least one device");
  if (it->size() > kMaxDevices)
    fail(where, fmt::format("header: {} devices, at most {} are supported", it->size(), kMaxDevices));
  for (std::size_t i = 0; i < it->size(); ++i) h.devices.push_back(device_from_json((*it)[i], where, i));
  return h;
}

std::string frame_to_json(const RecordingFrame& f) {
  std::string s = fmt::format("[{},{},[", f.t_us, f.device);
  for (std::size_t i = 0; i < f.events.size(); ++i)
    s += fmt::format("{}[{},{},{}]", i ? "," : "", f.events[i].type, f.events[i].code, f.events[i].value);
  s += "]]";
  return s;
}

namespace {

// The common shape of a frame line, [t, d, [[type, code, value], ...]] with
// integers, read without building a JSON tree (a 30 s recording has ~10k such
// lines; sanitized builds parse JSON slowly). Anything else, including every
// error, goes through the JSON parser, which says what is wrong.
std::optional<RecordingFrame> frame_fast(std::string_view s, std::size_t devices) {
  const char* p = s.data();
  const char* const end = p + s.size();
  auto ws = [&] {
    while (p < end && (*p == ' ' || *p == '\t' || *p == '\r')) ++p;
  };
  auto ch = [&](char c) {
    ws();
    if (p < end && *p == c) {
      ++p;
      return true;
    }
    return false;
  };
  auto num = [&](std::int64_t& v) {
    ws();
    const auto r = std::from_chars(p, end, v);
    if (r.ec != std::errc{}) return false;
    p = r.ptr;
    return p == end || *p == ',' || *p == ']' || *p == ' ';
  };
  RecordingFrame f;
  std::int64_t t = 0, d = 0;
  if (!ch('[') || !num(t) || !ch(',') || !num(d) || !ch(',') || !ch('[')) return std::nullopt;
  if (t < 0 || d < 0 || static_cast<std::uint64_t>(d) >= devices) return std::nullopt;
  if (!ch(']')) {
    do {
      std::int64_t type = 0, code = 0, value = 0;
      if (!ch('[') || !num(type) || !ch(',') || !num(code) || !ch(',') || !num(value) || !ch(']'))
        return std::nullopt;
      if (type < 0 || type > EV_MAX || code < 0 || code > 0x2ff || value < INT32_MIN || value > INT32_MAX)
        return std::nullopt;
      f.events.push_back({static_cast<std::uint16_t>(type), static_cast<std::uint16_t>(code),
                          static_cast<std::int32_t>(value)});
    } while (ch(','));
    if (!ch(']')) return std::nullopt;
  }
  if (!ch(']')) return std::nullopt;
  ws();
  if (p != end) return std::nullopt;
  f.t_us = t;
  f.device = static_cast<std::uint32_t>(d);
  return f;
}

// Any frame line, through the JSON parser: every error names what is wrong.
RecordingFrame frame_checked(std::string_view line, const std::string& where, std::size_t devices) {
  json j;
  try {
    j = json::parse(line);
  } catch (const json::parse_error& e) {
    fail(where, fmt::format("not valid JSON ({})", e.what()));
  }
  if (!j.is_array() || j.size() != 3)
    fail(where, "a frame must be [t_us, device, [[type, code, value], ...]]");
  RecordingFrame f;
  if (!j[0].is_number_integer() || int_value(j[0]) < 0 || int_value(j[0]) == INT64_MAX)
    fail(where, "t_us must be a non-negative integer (microseconds) below 2^63 - 1");
  f.t_us = int_value(j[0]);
  if (!j[1].is_number_integer()) fail(where, "device must be an integer index into the header's devices");
  const auto dev = int_value(j[1]);
  if (dev < 0 || static_cast<std::size_t>(dev) >= devices)
    fail(where, fmt::format("device {} does not exist (the header lists {})", j[1].dump(), devices));
  f.device = static_cast<std::uint32_t>(dev);
  if (!j[2].is_array()) fail(where, "events must be an array of [type, code, value]");
  for (std::size_t i = 0; i < j[2].size(); ++i) {
    const json& e = j[2][i];
    if (!e.is_array() || e.size() != 3 || !e[0].is_number_integer() || !e[1].is_number_integer() ||
        !e[2].is_number_integer())
      fail(where, fmt::format("event {} must be [type, code, value] integers", i));
    const auto type = int_value(e[0]), code = int_value(e[1]), value = int_value(e[2]);
    if (type < 0 || type > EV_MAX) fail(where, fmt::format("event {}: type {} out of range (0..{})", i, e[0].dump(), EV_MAX));
    if (code < 0 || code > 0x2ff) fail(where, fmt::format("event {}: code {} out of range (0..0x2ff)", i, e[1].dump()));
    if (value < INT32_MIN || value > INT32_MAX)
      fail(where, fmt::format("event {}: value {} out of range (a 32-bit signed integer)", i, e[2].dump()));
    f.events.push_back({static_cast<std::uint16_t>(type), static_cast<std::uint16_t>(code),
                        static_cast<std::int32_t>(value)});
  }
  return f;
}

}  // namespace

RecordingFrame frame_from_json(std::string_view line, const std::string& where, std::size_t devices) {
  if (auto f = frame_fast(line, devices)) return std::move(*f);
  return frame_checked(line, where, devices);
}

RecordingWriter::RecordingWriter(const std::filesystem::path& file, const RecordingHeader& header)
    : file_(file), out_(file, std::ios::out | std::ios::trunc), devices_(header.devices.size()) {
  if (!out_) throw RecordingError(fmt::format("{}: cannot open for writing", file.string()));
  if (header.devices.empty()) throw RecordingError(fmt::format("{}: a recording needs at least one device", file.string()));
  out_ << header_to_json(header) << '\n';
}

void RecordingWriter::write(const RecordingFrame& frame) { write(frame.t_us, frame.device, frame.events.data(), frame.events.size()); }

void RecordingWriter::write(std::int64_t t_us, std::uint32_t device, const InputEvent* events, std::size_t count) {
  if (device >= devices_) throw RecordingError(fmt::format("{}: frame for device {} of {}", file_.string(), device, devices_));
  if (t_us < last_t_) t_us = last_t_;  // time never runs backwards in a recording
  last_t_ = t_us;
  std::string s = fmt::format("[{},{},[", t_us, device);
  for (std::size_t i = 0; i < count; ++i)
    s += fmt::format("{}[{},{},{}]", i ? "," : "", events[i].type, events[i].code, events[i].value);
  s += "]]\n";
  out_ << s;
  ++frames_;
}

void RecordingWriter::close() {
  out_.flush();
  if (!out_) throw RecordingError(fmt::format("{}: write failed (disk full?)", file_.string()));
  out_.close();
}

RecordingReader::RecordingReader(const std::filesystem::path& file) : file_(file) {
  // A FIFO or a device would block or never end: regular files only.
  try {
    files::check_regular(file, kMaxRecordingBytes);
  } catch (const files::FileError& e) {
    throw RecordingError(fmt::format("{}: {}", file.string(), e.reason()));
  }
  in_.open(file, std::ios::binary);
  if (!in_) throw RecordingError(fmt::format("{}: cannot open the recording", file.string()));
  std::string line;
  if (!read_line(line)) throw RecordingError(fmt::format("{}:1: empty file, expected a recording header", file.string()));
  line_ = 1;
  header_ = header_from_json(line, fmt::format("{}:1", file.string()));
}

bool RecordingReader::read_line(std::string& line) {
  line.clear();
  std::streambuf* buf = in_.rdbuf();
  for (;;) {
    const int c = buf->sbumpc();
    if (c == std::char_traits<char>::eof()) return !line.empty();
    if (c == '\n') return true;
    if (line.size() == kMaxLineBytes)
      throw RecordingError(fmt::format("{}:{}: the line is longer than {} bytes: not a recording line", file_.string(),
                                     line_ + 1, kMaxLineBytes));
    line.push_back(static_cast<char>(c));
  }
}

std::optional<RecordingFrame> RecordingReader::next() {
  std::string line;
  while (read_line(line)) {
    ++line_;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;  // blank lines are allowed
    // The "file:line" is formatted only for a line the fast path does not take.
    auto where = [&] { return fmt::format("{}:{}", file_.string(), line_); };
    auto fast = frame_fast(line, header_.devices.size());
    RecordingFrame f = fast ? std::move(*fast) : frame_checked(line, where(), header_.devices.size());
    if (f.t_us < last_t_)
      fail(where(), fmt::format("t_us {} is earlier than the previous frame's {} (frames must be in time order)",
                                f.t_us, last_t_));
    last_t_ = f.t_us;
    return f;
  }
  if (in_.bad()) throw RecordingError(fmt::format("{}: read error after line {}", file_.string(), line_));
  return std::nullopt;
}

Recording read_recording(const std::filesystem::path& file) {
  RecordingReader r(file);
  Recording s;
  s.header = r.header();
  while (auto f = r.next()) s.frames.push_back(std::move(*f));
  return s;
}

void check_recording(const std::filesystem::path& file) {
  RecordingReader r(file);
  while (r.next()) {
  }
}

void write_recording(const std::filesystem::path& file, const Recording& recording) {
  RecordingWriter w(file, recording.header);
  for (const auto& f : recording.frames) w.write(f);
  w.close();
}

}  // namespace sculpt::input
