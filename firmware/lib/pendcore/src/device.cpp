#include "device.h"

#include <cmath>

namespace pend {
namespace {

int32_t round_half_up(double value) { return static_cast<int32_t>(std::floor(value + 0.5)); }

int32_t increment_for(int action) {
  switch (action) {
    case 1: return -kSlowStepCounts;
    case 2: return -kFastStepCounts;
    case 3: return kSlowStepCounts;
    case 4: return kFastStepCounts;
    default: return 0;
  }
}

uint32_t elapsed_ms(uint32_t now_ms, uint32_t then_ms) { return now_ms - then_ms; }  // wraps correctly

}  // namespace

Device::Device() : estimator_(kVelocityWindow, kEncoderCounts) { reset(round_half_up(kServoCentreCounts), 0); }

void Device::reset(int32_t servo_counts, uint32_t now_ms) {
  servo_counts_ = servo_counts;
  discrete_ = true;
  increment_counts_ = 0;
  target_unit_ = 0.0;
  last_command_ms_ = now_ms;
  estimator_.reset();
  filtered_unit_ = (servo_counts - kServoCentreCounts) * 2 / kServoSpanCounts;
  last_stream_servo_ = servo_counts;
  last_stream_ms_ = now_ms;
  has_raw_ = false;
  last_raw_ = 0;
  bad_frames_ = 0;
  servo_at_last_change_ = servo_counts;
  flags_ = 0;
  onboard_.stop();
  onboard_was_running_ = false;
  has_observation_ = false;
}

float Device::pendulum_rad(int32_t raw_counts) const {
  if (raw_counts < 0) return 0.0f;  // no reading yet
  const int32_t position = ((raw_counts - offset_counts_) % kEncoderCounts + kEncoderCounts) % kEncoderCounts;
  return static_cast<float>(position * (2 * M_PI / kEncoderCounts));
}

float Device::servo_rad(int32_t counts) const {
  return static_cast<float>((counts - kServoCentreCounts) * (2 * kServoRangeRad / kServoSpanCounts));
}

void Device::apply(const Command& command, uint32_t now_ms) {
  // An action or a target: the host takes over from the onboard controller.
  if (command.kind == CommandKind::kAction || command.kind == CommandKind::kTarget) {
    onboard_.stop();
    onboard_was_running_ = false;  // the host's command is in force, not a hold
  }
  switch (command.kind) {
    case CommandKind::kAction:
      discrete_ = true;
      increment_counts_ = increment_for(static_cast<int>(command.value));
      last_command_ms_ = now_ms;
      set(kFlagWatchdog, false);
      break;
    case CommandKind::kTarget:
      discrete_ = false;
      target_unit_ = command.value;
      last_command_ms_ = now_ms;
      set(kFlagWatchdog, false);
      break;
    case CommandKind::kHeartbeat:
      last_command_ms_ = now_ms;
      set(kFlagWatchdog, false);
      break;
    case CommandKind::kOnboard:
      last_command_ms_ = now_ms;
      set(kFlagWatchdog, false);
      if (command.value > 0) {
        onboard_.start(pendulum_rad(has_raw_ ? last_raw_ : -1), servo_rad(servo_counts_));
      } else {
        onboard_.stop();
      }
      break;
    case CommandKind::kEncoderOffset: offset_counts_ = static_cast<int32_t>(command.value); break;
    case CommandKind::kFilter: device_filter_ = command.value; break;
    case CommandKind::kWatchdogTimeout: watchdog_timeout_ms_ = command.value; break;
    case CommandKind::kOverspinLimit: overspin_limit_rev_s_ = command.value; break;
    case CommandKind::kSetVelocityWindow:  // a shorter mean lags less and is noisier; the history restarts
      estimator_ = VelocityEstimator(static_cast<int>(command.value));
      break;
    default: break;
  }
}

int32_t Device::act(uint32_t now_ms, int32_t raw_counts) {
  if (static_cast<double>(elapsed_ms(now_ms, last_command_ms_)) > watchdog_timeout_ms_) set(kFlagWatchdog, true);
  if (onboard_was_running_ && !onboard_.running()) {
    // stopped by k0, a new blob or anything else: hold here until the host commands, never resume the
    // host's command from before k1 (a stale target, or a policy's last ramp to the arm's limit)
    discrete_ = true;
    increment_counts_ = 0;
  }
  onboard_was_running_ = onboard_.running();
  int32_t wanted;
  PolicyDecision decision;
  const bool policy_runs = onboard_.running() && onboard_.runs_policy();
  if (policy_runs && onboard_.policy_tick(has_observation_ ? &last_observation_ : nullptr, now_ms, decision)) {
    discrete_ = !decision.continuous;  // as a host's command would, without feeding the watchdog
    if (decision.continuous) {
      target_unit_ = decision.target_unit;  // through the policy's own filter
    } else {
      increment_counts_ = increment_for(decision.action);
    }
  }
  if (onboard_.running() && !onboard_.runs_policy() && raw_counts >= 0) {
    const float target_rad = onboard_.tick(pendulum_rad(raw_counts), servo_rad(servo_counts_));
    const double counts = kServoCentreCounts + static_cast<double>(target_rad) * kServoSpanCounts / (2 * kServoRangeRad);
    wanted = std::isfinite(counts) ? round_half_up(counts) : servo_counts_;  // diverged (NaN): hold where it is
  } else if (!discrete_) {
    const double c = policy_runs ? 0.0 : device_filter_;
    filtered_unit_ = c * filtered_unit_ + (1 - c) * target_unit_;
    wanted = round_half_up(kServoCentreCounts + filtered_unit_ * kServoSpanCounts / 2);
  } else {
    wanted = servo_counts_ + increment_counts_;
  }
  if (flags_ & (kFlagWatchdog | kFlagOverspin | kFlagStuckEncoder)) wanted = servo_counts_;  // safety last
  int32_t clipped = wanted < kServoMinCounts ? kServoMinCounts : (wanted > kServoMaxCounts ? kServoMaxCounts : wanted);
  if (clipped != wanted || clipped == kServoMinCounts || clipped == kServoMaxCounts) {
    set(kFlagArmLimit, true);
    if (discrete_ && clipped != wanted) increment_counts_ = 0;  // a discrete action ends at the limit
  } else {
    set(kFlagArmLimit, false);
  }
  servo_counts_ = clipped;
  return clipped;
}

Observation Device::stream_frame(int64_t frame, uint32_t now_ms) {
  if (frame_status(frame) != FrameStatus::kOk) {
    if (++bad_frames_ >= kStuckBadFrames) set(kFlagStuckEncoder, true);
    return stream_raw(has_raw_ ? last_raw_ : offset_counts_, now_ms, true);
  }
  bad_frames_ = 0;
  return stream_raw(frame_position(static_cast<uint32_t>(frame)), now_ms, false);
}

Observation Device::stream_raw(int32_t raw_counts, uint32_t now_ms, bool frame_error) {
  if (!frame_error) {
    if (!has_raw_ || raw_counts != last_raw_) {
      servo_at_last_change_ = servo_counts_;
      if (bad_frames_ == 0) set(kFlagStuckEncoder, false);
    } else if (std::abs(servo_counts_ - servo_at_last_change_) >= kStuckTravelCounts) {
      set(kFlagStuckEncoder, true);
    }
    has_raw_ = true;
    last_raw_ = raw_counts;
  }
  const int32_t position = ((raw_counts - offset_counts_) % kEncoderCounts + kEncoderCounts) % kEncoderCounts;
  const Estimate estimate = estimator_.update(position, now_ms);
  set(kFlagOverspin, overspin_limit_rev_s_ > 0 && std::fabs(estimate.omega_rev_s) > overspin_limit_rev_s_);
  const double dt_ms = static_cast<double>(static_cast<int64_t>(now_ms) - static_cast<int64_t>(last_stream_ms_));
  const double arm_velocity = dt_ms > 0 ? (servo_counts_ - last_stream_servo_) * 1000.0 / dt_ms : 0.0;
  last_stream_servo_ = servo_counts_;
  last_stream_ms_ = now_ms;
  const uint8_t flags = static_cast<uint8_t>(flags_ | (frame_error ? kFlagFrameError : 0));
  last_observation_ = Observation{now_ms, position, servo_counts_, estimate.omega_rev_s, estimate.accel_rev_s2,
                                  arm_velocity, flags};
  has_observation_ = true;
  return last_observation_;
}

bool Schedule::due(uint32_t now_ms) {
  if (static_cast<int32_t>(now_ms - next_ms_) < 0) return false;
  next_ms_ += period_ms_;
  if (static_cast<int32_t>(now_ms - next_ms_) >= 0) next_ms_ = now_ms + period_ms_;  // missed ticks: skip
  return true;
}

}  // namespace pend
