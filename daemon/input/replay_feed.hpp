// Reads a replay on its own thread, so the io thread never waits on the
// recording: the reader runs `ahead` messages in front of what the io
// thread has taken, and the io thread moves them into the simulation's
// input ring (memory only) whenever it likes.
//
//   ReplaySource src(file, rate, binder);
//   src.start(1);
//   while (auto m = src.next()) { ... }   // the attaches, bound on this thread
//   ReplayFeed feed(std::move(src), 4096);
//   feed.pump(sim_ring);                  // io thread, every few ms
//   if (auto e = feed.error()) ...        // a line that went bad after the start's check
//
// A frame is never lost or reordered between the file and `ring`: the
// simulation gets exactly what ReplaySource::next() gives, in order.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <thread>

#include "concurrency/spsc_ring.hpp"
#include "input/input_message.hpp"
#include "input/replay_source.hpp"

namespace sculpt::input {

class ReplayFeed {
 public:
  // Takes the source once the caller has taken what it wants on its own
  // thread (the attaches, whose binder is not thread-safe). Reads the first
  // `ahead` messages right here, so a pump() straight after has them (the
  // first ticks' frames must be queued before the simulation starts; a bad
  // line among them throws RecordingError), then goes on on its thread.
  ReplayFeed(ReplaySource source, std::size_t ahead);
  ~ReplayFeed();  // stops the reader
  ReplayFeed(const ReplayFeed&) = delete;
  ReplayFeed& operator=(const ReplayFeed&) = delete;

  const RecordingHeader& header() const { return header_; }

  // Moves read messages into `ring` until only `keep_free` slots are left
  // or nothing is read yet. Returns how many. One consumer thread only.
  // (The daemon keeps a slot per device free: a scene swap re-sends every
  // device's attach ahead of what was queued, into a ring of the same size.)
  std::size_t pump(concurrency::SpscRing<InputMessage>& ring, std::size_t keep_free = 0);
  // The reader reached the end of the recording (or an error) and every
  // message it read has been pumped.
  bool finished() const;
  // Why the reader stopped early (a bad line, an I/O error), once it has and
  // everything before it has been pumped.
  std::optional<std::string> error() const;

 private:
  void read();

  RecordingHeader header_;
  ReplaySource source_;
  concurrency::SpscRing<InputMessage> read_;
  std::optional<InputMessage> held_;     // taken from read_ but not yet into a full ring
  std::atomic<std::uint32_t> taken_{0};  // bumped by pump(): the reader waits on it when read_ is full
  std::atomic<bool> done_{false};        // the reader has stopped; read_ holds all it will
  std::atomic<bool> stop_{false};
  std::string error_;  // written before done_ (release)
  std::thread reader_;
};

}  // namespace sculpt::input
