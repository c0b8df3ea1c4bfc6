// Recorded sessions (docs/session-format.md): JSON Lines, versioned.
//   line 1: {"format":"sculpt-session","version":1,"devices":[{...}, ...], ...}
//   then one line per frame: [t_us, device, [[type, code, value], ...]]
// t_us counts microseconds from the start of the recording (non-decreasing);
// device indexes the header's device list.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "input/device_info.hpp"
#include "input/input_message.hpp"

namespace sculpt::input {

inline constexpr std::string_view kSessionFormat = "sculpt-session";
inline constexpr int kSessionVersion = 1;

struct SessionFrame {
  std::int64_t t_us = 0;
  std::uint32_t device = 0;
  std::vector<InputEvent> events;
  bool operator==(const SessionFrame&) const = default;
};

struct SessionHeader {
  int version = kSessionVersion;
  std::vector<DeviceInfo> devices;
  std::string description;   // free text: what the session does
};

class SessionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class SessionWriter {
 public:
  // Writes the header at once. Throws SessionError naming the file.
  SessionWriter(const std::filesystem::path& file, const SessionHeader& header);
  void write(const SessionFrame& frame);
  void write(std::int64_t t_us, std::uint32_t device, const InputEvent* events, std::size_t count);
  // Flushes and checks the stream; throws SessionError when the disk refused.
  void close();
  std::size_t frames() const { return frames_; }

 private:
  std::filesystem::path file_;
  std::ofstream out_;
  std::size_t devices_;
  std::size_t frames_ = 0;
  std::int64_t last_t_ = 0;
};

class SessionReader {
 public:
  // Regular files only (a FIFO would block the reader), of at most this many
  // bytes, in lines of at most kMaxLineBytes.
  static constexpr std::uint64_t kMaxSessionBytes = std::uint64_t{4} << 30;
  static constexpr std::size_t kMaxLineBytes = 1 << 20;

  // Reads and checks the header. Errors name file:line and what is wrong.
  explicit SessionReader(const std::filesystem::path& file);
  const SessionHeader& header() const { return header_; }
  // The next frame, nullopt at the end. Throws SessionError on bad lines.
  std::optional<SessionFrame> next();
  const std::filesystem::path& file() const { return file_; }

 private:
  bool read_line(std::string& line);  // false at the end

  std::filesystem::path file_;
  std::ifstream in_;
  SessionHeader header_;
  unsigned line_ = 0;
  std::int64_t last_t_ = 0;
};

// Whole-file helpers (small sessions, tests, the generator's checks).
struct Session {
  SessionHeader header;
  std::vector<SessionFrame> frames;
};
Session read_session(const std::filesystem::path& file);
// Reads every line (one at a time: bounded memory) and throws SessionError at
// the first bad one: a replay checks its whole file before its first tick.
void check_session(const std::filesystem::path& file);
void write_session(const std::filesystem::path& file, const Session& session);

// Text forms, exposed for tests and tools.
std::string header_to_json(const SessionHeader& header);
SessionHeader header_from_json(std::string_view line, const std::string& where);
std::string frame_to_json(const SessionFrame& frame);
SessionFrame frame_from_json(std::string_view line, const std::string& where, std::size_t devices);

}  // namespace sculpt::input
