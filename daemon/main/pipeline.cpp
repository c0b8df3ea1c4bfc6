#include "main/pipeline.hpp"

#include <stdexcept>
#include <string>

namespace sculpt::daemon {

SculptStages::SculptStages(loop::ToolDriver driver, haptics::FeedbackBoard& board, std::size_t ring_capacity)
    : driver_(std::move(driver)), board_(board), ring_(ring_capacity), mapper_(driver_.size()) {
  if (driver_.size() > input::kMaxTools)
    throw std::invalid_argument("the scene has " + std::to_string(driver_.size()) + " tools; at most " +
                                std::to_string(input::kMaxTools) + " can be driven");
}

void SculptStages::input(std::uint64_t tick, std::span<sim::Tool> tools) {
  const std::size_t n = mapper_.drain(ring_, tick);
  if (n) applied_.store(applied_.load(std::memory_order_relaxed) + n, std::memory_order_relaxed);
  driver_.update_from(mapper_.controls(), tools);
  tools_ = tools;
}

void SculptStages::publish(std::uint64_t tick, const sim::World<float>& world) {
  if (published_) published_->publish(tick, world, tools_, loop::monotonic_ns());
  const auto feedback = world.feedback();
  for (std::size_t t = 0; t < driver_.size() && t < feedback.size(); ++t) {
    if (driver_.tool(t).active) board_.publish(static_cast<int>(t), feedback[t]);
    else board_.clear(static_cast<int>(t));
  }
}

}  // namespace sculpt::daemon
