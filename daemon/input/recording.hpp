// Recordings (docs/recording-format.md): JSON Lines, versioned.
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

inline constexpr std::string_view kRecordingFormat = "sculpt-session";
inline constexpr int kRecordingVersion = 1;

struct RecordingFrame {
  std::int64_t t_us = 0;
  std::uint32_t device = 0;
  std::vector<InputEvent> events;
  bool operator==(const RecordingFrame&) const = default;
};

struct RecordingHeader {
  int version = kRecordingVersion;
  std::vector<DeviceInfo> devices;
  std::string description;   // free text: what the recording does
};

class RecordingError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class RecordingWriter {
 public:
  // Writes the header at once. Throws RecordingError naming the file.
  RecordingWriter(const std::filesystem::path& file, const RecordingHeader& header);
  void write(const RecordingFrame& frame);
  void write(std::int64_t t_us, std::uint32_t device, const InputEvent* events, std::size_t count);
  // Flushes and checks the stream; throws RecordingError when the disk refused.
  void close();
  std::size_t frames() const { return frames_; }

 private:
  std::filesystem::path file_;
  std::ofstream out_;
  std::size_t devices_;
  std::size_t frames_ = 0;
  std::int64_t last_t_ = 0;
};

class RecordingReader {
 public:
  // Regular files only (a FIFO would block the reader), of at most this many
  // bytes, in lines of at most kMaxLineBytes.
  static constexpr std::uint64_t kMaxRecordingBytes = std::uint64_t{4} << 30;
  static constexpr std::size_t kMaxLineBytes = 1 << 20;

  // Reads and checks the header. Errors name file:line and what is wrong.
  explicit RecordingReader(const std::filesystem::path& file);
  const RecordingHeader& header() const { return header_; }
  // The next frame, nullopt at the end. Throws RecordingError on bad lines.
  std::optional<RecordingFrame> next();
  const std::filesystem::path& file() const { return file_; }

 private:
  bool read_line(std::string& line);  // false at the end

  std::filesystem::path file_;
  std::ifstream in_;
  RecordingHeader header_;
  unsigned line_ = 0;
  std::int64_t last_t_ = 0;
};

// Whole-file helpers (small recordings, tests, the generator's checks).
struct Recording {
  RecordingHeader header;
  std::vector<RecordingFrame> frames;
};
Recording read_recording(const std::filesystem::path& file);
// Reads every line (one at a time: bounded memory) and throws RecordingError at
// the first bad one: a replay checks its whole file before its first tick.
void check_recording(const std::filesystem::path& file);
void write_recording(const std::filesystem::path& file, const Recording& recording);

// Text forms, exposed for tests and tools.
std::string header_to_json(const RecordingHeader& header);
RecordingHeader header_from_json(std::string_view line, const std::string& where);
std::string frame_to_json(const RecordingFrame& frame);
RecordingFrame frame_from_json(std::string_view line, const std::string& where, std::size_t devices);

}  // namespace sculpt::input
