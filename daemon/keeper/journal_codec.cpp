#include "keeper/journal_codec.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <stdexcept>

#include "sim/state_bytes.hpp"

namespace sculpt::daemon {
namespace {

constexpr std::uint8_t kLastKind = static_cast<std::uint8_t>(JournalEntry::Kind::reached);

struct PackedEvent {
  std::uint16_t type, code;
  std::int32_t value;
};

void encode_message(sim::StateWriter& w, const input::InputMessage& m) {
  w.value(static_cast<std::uint8_t>(m.kind)), w.value(m.slot);
  if (m.kind == input::MessageKind::attach) w.value(m.binding);
  if (m.kind != input::MessageKind::frame) return;
  const std::uint16_t n = std::min<std::uint16_t>(m.frame.count, input::kMaxFrameEvents);
  w.value(n);
  for (std::uint16_t i = 0; i < n; ++i) w.value(PackedEvent{m.frame.events[i].type, m.frame.events[i].code, m.frame.events[i].value});
}

void decode_message(sim::StateReader& r, input::InputMessage& m) {
  std::uint8_t kind = 0;
  r.value(kind, "message kind"), r.value(m.slot, "device slot");
  if (kind > static_cast<std::uint8_t>(input::MessageKind::frame)) throw std::invalid_argument("unknown message kind");
  if (m.slot >= input::kMaxDevices) throw std::invalid_argument("device slot out of range");
  m.kind = static_cast<input::MessageKind>(kind);
  if (m.kind == input::MessageKind::attach) {
    r.value(m.binding, "binding");
    if (const std::string error = input::binding_error(m.binding); !error.empty()) throw std::invalid_argument(error);
  }
  if (m.kind != input::MessageKind::frame) return;
  m.frame.slot = m.slot;
  r.value(m.frame.count, "event count");
  if (m.frame.count > input::kMaxFrameEvents) throw std::invalid_argument("too many events in a frame");
  for (std::uint16_t i = 0; i < m.frame.count; ++i) {
    PackedEvent e{};
    r.value(e, "event");
    m.frame.events[i] = {e.type, e.code, e.value};
  }
}

}  // namespace

void encode_entry(const JournalEntry& e, std::vector<std::byte>& out) {
  sim::StateWriter w(out);
  w.value(static_cast<std::uint8_t>(e.kind));
  switch (e.kind) {
    case JournalEntry::Kind::message: encode_message(w, e.message); break;
    case JournalEntry::Kind::history_move: w.value(e.number), w.value(static_cast<std::uint8_t>(e.refused)); break;
    case JournalEntry::Kind::scene: w.value(e.number); break;
    case JournalEntry::Kind::reached: w.value(e.wall_ns); break;
    case JournalEntry::Kind::pause:
    case JournalEntry::Kind::resume: break;
  }
}

std::optional<JournalEntry> decode_entry(std::span<const std::byte> bytes, std::uint64_t tick, std::string& error) {
  try {
    sim::StateReader r(bytes, /*dry=*/false);
    JournalEntry e;
    e.tick = tick;
    std::uint8_t kind = 0;
    r.value(kind, "entry kind");
    if (kind > kLastKind) throw std::invalid_argument("unknown entry kind " + std::to_string(kind));
    e.kind = static_cast<JournalEntry::Kind>(kind);
    if (e.kind == JournalEntry::Kind::message) decode_message(r, e.message);
    if (e.kind == JournalEntry::Kind::history_move || e.kind == JournalEntry::Kind::scene) r.value(e.number, "number");
    if (e.kind == JournalEntry::Kind::reached) r.value(e.wall_ns, "commit time");
    if (e.kind == JournalEntry::Kind::history_move) {
      std::uint8_t refused = 0;
      r.value(refused, "history move outcome");
      e.refused = refused != 0;
    }
    if (!r.done()) throw std::invalid_argument("bytes left over");
    return e;
  } catch (const std::invalid_argument& x) {
    error = x.what();
    return std::nullopt;
  }
}

}  // namespace sculpt::daemon
