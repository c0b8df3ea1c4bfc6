#include "haptics/pacer.hpp"

#include <algorithm>

namespace sculpt::haptics {

bool ConstantPacer::should_send(const ConstantCommand& want, Clock::time_point now) const {
  if (!has_sent_) return true;
  if (now - last_at_ < interval_) return false;
  if (retry_) return true;
  return is_real_change(last_, want, threshold_);
}

void ConstantPacer::sent(const ConstantCommand& c, Clock::time_point now) {
  has_sent_ = true;
  retry_ = false;
  last_ = c;
  last_at_ = now;
}

void ConstantPacer::failed(Clock::time_point now) {
  has_sent_ = true;
  retry_ = true;
  last_at_ = now;
}

void KickPacer::onset(double impulse) {
  pending_impulse_ = pending_ ? std::max(pending_impulse_, impulse) : impulse;
  pending_ = true;
}

bool KickPacer::due(Clock::time_point now) const {
  if (!pending_) return false;
  return !has_kicked_ || now - last_at_ >= interval_;
}

void KickPacer::kicked(Clock::time_point now) {
  pending_ = false;
  pending_impulse_ = 0;
  has_kicked_ = true;
  last_at_ = now;
}

}  // namespace sculpt::haptics
