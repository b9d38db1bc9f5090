#include "encoder.h"

namespace pend {

const char* frame_status_name(FrameStatus status) {
  switch (status) {
    case FrameStatus::kOk: return "ok";
    case FrameStatus::kFrameWidth: return "frame_width";
    case FrameStatus::kParity: return "parity";
    case FrameStatus::kOffsetCompensationNotFinished: return "offset_compensation_not_finished";
    case FrameStatus::kCordicOverflow: return "cordic_overflow";
    case FrameStatus::kLinearityAlarm: return "linearity_alarm";
    case FrameStatus::kMagnetOutOfRange: return "magnet_out_of_range";
  }
  return "unknown";
}

FrameStatus frame_status(int64_t frame) {
  if (frame < 0 || frame >= (1 << 16)) return FrameStatus::kFrameWidth;
  uint32_t bits = static_cast<uint32_t>(frame);
  int ones = 0;
  for (uint32_t rest = bits; rest != 0; rest &= rest - 1) ++ones;
  if (ones % 2 != 0) return FrameStatus::kParity;
  if (((bits >> 5) & 1u) == 0) return FrameStatus::kOffsetCompensationNotFinished;
  if ((bits >> 4) & 1u) return FrameStatus::kCordicOverflow;
  if ((bits >> 3) & 1u) return FrameStatus::kLinearityAlarm;
  if (((bits >> 2) & 1u) && ((bits >> 1) & 1u)) return FrameStatus::kMagnetOutOfRange;
  return FrameStatus::kOk;
}

int32_t wrap_delta(int32_t new_counts, int32_t old_counts, int32_t counts) {
  const int32_t delta = new_counts - old_counts;
  const int32_t half = counts / 2;
  if (delta > half) return delta - counts;
  if (delta < -half) return delta + counts;
  return delta;
}

VelocityEstimator::VelocityEstimator(int window, int32_t counts)
    : window_(window < 1 ? 1 : (window > kMaxWindow ? kMaxWindow : window)), counts_(counts) {
  reset();
}

void VelocityEstimator::reset() {
  for (double& value : ring_) value = 0.0;
  index_ = 0;
  has_last_ = false;
  last_position_ = 0;
  last_time_ms_ = 0;
  last_mean_ = 0.0;
}

Estimate VelocityEstimator::update(int32_t position, uint32_t now_ms) {
  double raw = 0.0;
  double dt_ms = 0.0;
  if (has_last_) {
    dt_ms = static_cast<double>(static_cast<int64_t>(now_ms) - static_cast<int64_t>(last_time_ms_));
    if (dt_ms > 0) {
      raw = wrap_delta(position, last_position_, counts_) * 1000.0 / (static_cast<double>(counts_) * dt_ms);
    }
  }
  ring_[index_] = raw;
  index_ = (index_ + 1) % window_;
  double sum = 0.0;
  for (int i = 0; i < window_; ++i) sum += ring_[i];  // same order as the Python reference
  const double mean = sum / window_;
  const double accel = (has_last_ && dt_ms > 0) ? (mean - last_mean_) * 1000.0 / dt_ms : 0.0;
  has_last_ = true;
  last_position_ = position;
  last_time_ms_ = now_ms;
  last_mean_ = mean;
  return Estimate{mean, accel};
}

}  // namespace pend
