// --input: where tool controls come from, and which clock times them
// (docs/config.md). Parsed from the config and the command line
// (main/config.hpp: parse_input_spec); the input source opens it.
#pragma once

#include <filesystem>

namespace sculpt::daemon {

struct InputSpec {
  enum class Kind { automatic, evdev, replay };
  Kind kind = Kind::automatic;   // auto: live devices, udev when udevd runs, else inotify on /dev/input
  std::filesystem::path replay;  // replay:FILE
};

enum class InputClock { arrival, device };

}  // namespace sculpt::daemon
