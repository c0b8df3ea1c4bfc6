#include "haptics/haptics_thread.hpp"

#include <time.h>

#include <stdexcept>
#include <string>
#include <utility>

namespace sculpt::haptics {

HapticsThread::HapticsThread(const FeedbackBoard& board, HapticsSettings settings, PortOpener opener, LogSink log)
    : engine_(board, settings, std::move(opener), stats_, std::move(log)), poll_interval_(settings.poll_interval) {}

HapticsThread::~HapticsThread() { stop(); }

void HapticsThread::start() {
  if (thread_.joinable()) return;
  {
    std::lock_guard lock(mutex_);
    stopping_ = false;
  }
  thread_ = std::thread([this] { run(); });
}

void HapticsThread::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  engine_.shutdown();  // the thread has ended: safe here too (idempotent)
  done_.notify_all();
}

void HapticsThread::push(Command c) {
  {
    std::lock_guard lock(mutex_);
    queue_.push_back(std::move(c));
  }
  wake_.notify_all();
}

void HapticsThread::attach(int slot, std::string node, std::vector<ToolStick> tools, TriggerBinding triggers) {
  push(Attach{slot, std::move(node), std::move(tools), triggers});
}
void HapticsThread::detach(int slot) { push(Detach{slot}); }
void HapticsThread::configure(const HapticsSettings& settings) { push(Configure{settings}); }

void HapticsThread::tune(int slot, DeviceTuning t) {
  check_tuning(t);
  if (slot < 0 || slot >= HapticsStats::kSlots)
    throw std::invalid_argument("slot " + std::to_string(slot) + " is not within [0, " +
                                std::to_string(HapticsStats::kSlots - 1) + "]");
  // Seen by tuning() at once; the engine applies it at its next poll.
  stats_.slot_gain[static_cast<std::size_t>(slot)].store(t.gain, std::memory_order_relaxed);
  stats_.slot_limit[static_cast<std::size_t>(slot)].store(t.limit, std::memory_order_relaxed);
  push(Tune{slot, t});
}

void HapticsThread::resumed() { push(Resumed{}); }

DeviceTuning HapticsThread::tuning(int slot) const {
  if (slot < 0 || slot >= HapticsStats::kSlots) return {};
  const auto i = static_cast<std::size_t>(slot);
  return {stats_.slot_gain[i].load(std::memory_order_relaxed), stats_.slot_limit[i].load(std::memory_order_relaxed)};
}

std::uint16_t HapticsThread::bustype(int slot) const {
  if (slot < 0 || slot >= HapticsStats::kSlots) return 0;
  return stats_.slot_bustype[static_cast<std::size_t>(slot)].load(std::memory_order_relaxed);
}

namespace {
// CLOCK_BOOTTIME goes on through a suspend; steady_clock (CLOCK_MONOTONIC) does not.
std::chrono::nanoseconds boottime() {
  timespec ts{};
  ::clock_gettime(CLOCK_BOOTTIME, &ts);
  return std::chrono::seconds(ts.tv_sec) + std::chrono::nanoseconds(ts.tv_nsec);
}
}  // namespace

void HapticsThread::flush() {
  std::unique_lock lock(mutex_);
  if (!thread_.joinable()) return;
  // Two completed polls from now: the second one started after this call,
  // with every command queued before it applied.
  const std::uint64_t target = polls_ + 2;
  wake_now_ = true;
  wake_.notify_all();
  done_.wait(lock, [&] { return polls_ >= target || stopping_; });
}

void HapticsThread::run() {
  auto next = Clock::now();
  std::deque<Command> batch;
  for (;;) {
    {
      // A zero waiting for a device's pacer goes out when the pacer allows,
      // not at the next tick after.
      const auto due = engine_.next_due();
      std::unique_lock lock(mutex_);
      wake_.wait_until(lock, due && *due < next ? *due : next,
                       [&] { return stopping_ || wake_now_ || !queue_.empty(); });
      if (stopping_) break;
      wake_now_ = false;
      batch.swap(queue_);
    }
    for (auto& c : batch) {
      if (auto* a = std::get_if<Attach>(&c)) {
        engine_.attach(a->slot, a->node, std::move(a->tools), a->triggers);
      } else if (auto* d = std::get_if<Detach>(&c)) {
        engine_.detach(d->slot);
      } else if (auto* s = std::get_if<Configure>(&c)) {
        engine_.configure(s->settings);
        poll_interval_ = s->settings.poll_interval;
      } else if (auto* t = std::get_if<Tune>(&c)) {
        engine_.tune(t->slot, t->tuning);
      } else if (std::holds_alternative<Resumed>(c)) {
        engine_.resumed("logind PrepareForSleep");
      }
    }
    batch.clear();
    const auto now = Clock::now();
    engine_.poll(boottime());  // early (a command, a flush, a zero due): applied now, the schedule kept
    if (now >= next) {
      next += poll_interval_;
      if (next <= now) next = now + poll_interval_;  // fell behind (a slow ioctl): no burst to catch up
    }
    {
      std::lock_guard lock(mutex_);
      ++polls_;
    }
    done_.notify_all();
  }
  engine_.shutdown();
}

}  // namespace sculpt::haptics
