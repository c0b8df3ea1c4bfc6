// At most one log line per key per interval for something a client may
// change as often as it likes (`sculptctl haptics SLOT --gain`): one client
// must not be able to fill the journal. The first change is said at once;
// later ones within the interval are counted, and the last of them is said
// with the count once the interval has run out (due(), from the io loop's
// housekeeping), so the log always ends with the value in force.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

namespace sculpt::daemon {

class ChangeLog {
 public:
  using Clock = std::chrono::steady_clock;
  explicit ChangeLog(Clock::duration every) : every_(every) {}

  // The line to log now for a change of `key` described by `text`, or
  // nullopt: held, due() says it.
  std::optional<std::string> changed(std::uint32_t key, std::string text, Clock::time_point now) {
    auto [it, fresh] = keys_.try_emplace(key);
    Held& h = it->second;
    if (fresh || now - h.said >= every_) {
      std::string line = h.count == 0 ? text : fmt::format("{} ({} earlier changes not logged)", text, h.count);
      h = Held{now, {}, 0};
      return line;
    }
    h.text = std::move(text);
    ++h.count;
    return std::nullopt;
  }

  // The held lines whose interval has run out.
  std::vector<std::string> due(Clock::time_point now) {
    std::vector<std::string> lines;
    for (auto& [key, h] : keys_) {
      if (h.count == 0 || now - h.said < every_) continue;
      lines.push_back(fmt::format("{} (the last of {} changes in {:.0f} s)", h.text, h.count,
                                  std::chrono::duration<double>(now - h.said).count()));
      h = Held{now, {}, 0};
    }
    return lines;
  }

 private:
  struct Held {
    Clock::time_point said{};  // when a line of this key was last logged
    std::string text;          // the newest change not logged
    std::uint64_t count = 0;   // changes not logged
  };
  Clock::duration every_;
  std::map<std::uint32_t, Held> keys_;
};

}  // namespace sculpt::daemon
