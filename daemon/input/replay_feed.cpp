#include "input/replay_feed.hpp"

#include <exception>

namespace sculpt::input {

ReplayFeed::ReplayFeed(ReplaySource source, std::size_t ahead)
    : header_(source.header()), source_(std::move(source)), read_(ahead) {
  bool more = true;
  while (more && read_.size() < read_.capacity()) {
    const std::optional<InputMessage> m = source_.next();
    more = m && read_.try_push(*m);
  }
  if (more)
    reader_ = std::thread([this] { read(); });
  else
    done_.store(true, std::memory_order_release);
}

ReplayFeed::~ReplayFeed() {
  stop_.store(true, std::memory_order_release);
  taken_.fetch_add(1, std::memory_order_release);
  taken_.notify_one();
  if (reader_.joinable()) reader_.join();
}

void ReplayFeed::read() {
  try {
    while (!stop_.load(std::memory_order_acquire)) {
      const std::optional<InputMessage> m = source_.next();
      if (!m) break;
      for (;;) {
        // Read before trying, so a pump() between the try and the wait
        // wakes us (the value has moved on).
        const std::uint32_t seen = taken_.load(std::memory_order_acquire);
        if (read_.try_push(*m)) break;
        if (stop_.load(std::memory_order_acquire)) break;
        taken_.wait(seen, std::memory_order_acquire);
      }
    }
  } catch (const std::exception& e) {
    error_ = e.what();
  }
  done_.store(true, std::memory_order_release);
}

std::size_t ReplayFeed::pump(concurrency::SpscRing<InputMessage>& ring, std::size_t keep_free) {
  std::size_t n = 0;
  // size() only shrinks while this producer waits: the room it sees is there.
  while (ring.size() + keep_free < ring.capacity()) {
    if (!held_) held_ = read_.try_pop();
    if (!held_ || !ring.try_push(*held_)) break;
    held_.reset();
    ++n;
  }
  if (n > 0) {
    taken_.fetch_add(1, std::memory_order_release);
    taken_.notify_one();
  }
  return n;
}

bool ReplayFeed::finished() const {
  // done_ first: once it is set, read_ holds everything the reader will put there.
  return done_.load(std::memory_order_acquire) && !held_ && read_.size() == 0;
}

std::optional<std::string> ReplayFeed::error() const {
  if (!finished() || error_.empty()) return std::nullopt;
  return error_;
}

}  // namespace sculpt::input
