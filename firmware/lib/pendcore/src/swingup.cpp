#include "swingup.h"

#include <cmath>

namespace pend {

namespace {

constexpr float kPi = 3.14159265358979f;
constexpr float kEarlierSwingRad = 1.2f;
constexpr int kArmSubsteps = 2;

float wrap_pi(float angle) {
  float wrapped = std::fmod(angle + kPi, 2 * kPi);
  if (wrapped < 0) wrapped += 2 * kPi;
  return wrapped - kPi;
}
float clamp(float value, float limit) { return value > limit ? limit : (value < -limit ? -limit : value); }

}  // namespace

const char* swing_mode_name(SwingMode mode) {
  switch (mode) {
    case SwingMode::kWait: return "wait";
    case SwingMode::kTrack: return "track";
    case SwingMode::kSettle: return "settle";
    case SwingMode::kSwing: return "swing";
    case SwingMode::kBalance: return "balance";
  }
  return "?";
}

void SwingUp::set_params(const SwingUpParams& params) {
  p_ = params;
  const long ticks = std::lround(s(kPeriodS) / s(kActingPeriodS));
  ticks_per_step_ = ticks < 1 ? 1 : static_cast<int>(ticks);
  reset(0, 0);
}

void SwingUp::reset(float pendulum_rad, float target_rad) {
  angle_ = pendulum_rad;
  rate_ = 0;
  arm_ = target_rad;
  arm_rate_ = 0;
  servo_sees_ = target_rad;
  output_ = swing_target_ = filtered_ = target_rad;
  mode_ = p_.warmup_steps > 0 ? SwingMode::kWait : first_mode();
  tick_count_ = 0;
  steps_ = plan_step_ = 0;
}

float SwingUp::arm_acceleration(float target_rad) const {
  const float drive = s(kServoKpPerInertia) * (target_rad - arm_) - s(kServoKvPerInertia) * arm_rate_;
  return clamp(drive, s(kStallPerInertia)) - s(kArmDampingPerInertia) * arm_rate_;
}

// The servo takes a new target at its next PWM frame, which the device does not see: the arm's model
// is driven by the target in force one acting tick back (half a 20 ms frame on average).
void SwingUp::observe(float pendulum_rad, float target_in_force_rad) {
  const float dt = s(kActingPeriodS);
  const float target_rad = servo_sees_;
  servo_sees_ = target_in_force_rad;
  const float push = arm_acceleration(target_rad);
  const float h = dt / kArmSubsteps;
  for (int k = 0; k < kArmSubsteps; ++k) {  // semi-implicit Euler
    arm_rate_ += h * arm_acceleration(target_rad);
    arm_ += h * arm_rate_;
  }
  const float w0 = s(kNaturalFrequency);
  const float acceleration = -w0 * w0 * std::sin(angle_) - s(kPendulumDampingPerInertia) * rate_ -
                             s(kCouplingPerInertia) * std::cos(angle_) * push;
  const float predicted = angle_ + rate_ * dt + 0.5f * acceleration * dt * dt;
  const float rate = rate_ + acceleration * dt;
  const float innovation = wrap_pi(pendulum_rad - predicted);
  angle_ = wrap_pi(predicted + s(kObserverAngleGain) * innovation);
  rate_ = rate + s(kObserverRateGain) * innovation;
}

float SwingUp::tick(float pendulum_rad, float target_in_force_rad) {
  observe(pendulum_rad, target_in_force_rad);
  if (++tick_count_ >= ticks_per_step_) {
    tick_count_ = 0;
    output_ = control_step();
  }
  return output_;
}

SwingMode SwingUp::first_mode() const {
  const bool at_rest = std::fabs(wrap_pi(angle_)) < s(kRestAngle) && std::fabs(rate_) < s(kRestVelocity);
  return p_.plan_steps > 0 && at_rest ? SwingMode::kTrack : SwingMode::kSwing;
}

float SwingUp::control_step() {
  ++steps_;
  if (mode_ == SwingMode::kWait) {
    if (steps_ < p_.warmup_steps) return output_;
    mode_ = first_mode();
  }
  float target = 0;
  if (mode_ == SwingMode::kTrack && track(target)) return clamp(target, s(kServoRange));
  if (mode_ == SwingMode::kSettle && settle(target)) return clamp(target, s(kServoRange));
  return swing_or_balance();
}

bool SwingUp::track(float& target) {
  if (plan_step_ >= p_.plan_steps) {
    mode_ = SwingMode::kSettle;
    plan_step_ = 0;
    return false;
  }
  const float x[5] = {arm_, angle_, arm_rate_, rate_, output_};
  const float* planned = p_.plan_state[plan_step_];
  float error[5];
  for (int i = 0; i < 5; ++i) error[i] = x[i] - planned[i];
  error[1] = wrap_pi(error[1]);
  if (std::fabs(error[1]) > s(kDriftRad)) {  // off the plan: pump instead (the device does not re-plan)
    mode_ = SwingMode::kSwing;
    swing_target_ = output_;
    return false;
  }
  target = p_.plan_target[plan_step_];
  for (int i = 0; i < 5; ++i) target -= p_.plan_gain[plan_step_][i] * error[i];
  ++plan_step_;
  return true;
}

bool SwingUp::settle(float& target) {
  const float x[5] = {arm_, wrap_pi(angle_ - kPi), arm_rate_, rate_, output_};
  if (plan_step_ >= p_.settle_steps || std::fabs(x[1]) > s(kFallAngle)) {
    mode_ = SwingMode::kSwing;
    swing_target_ = output_;
    return false;
  }
  target = 0;
  for (int i = 0; i < 5; ++i) target -= p_.settle_gain[i] * x[i];
  ++plan_step_;
  return true;
}

float SwingUp::swing_or_balance() {
  const float theta = wrap_pi(angle_ - kPi);
  if (mode_ == SwingMode::kSwing && std::fabs(theta) < s(kCatchAngle) && std::fabs(rate_) < s(kCatchVelocity)) {
    mode_ = SwingMode::kBalance;
    filtered_ = clamp(arm_, s(kServoRange));
  } else if (mode_ == SwingMode::kBalance && std::fabs(theta) > s(kFallAngle)) {
    mode_ = SwingMode::kSwing;
    swing_target_ = output_;
  }
  if (mode_ == SwingMode::kBalance) {
    const float x[5] = {arm_, theta, arm_rate_, rate_, filtered_};
    float u = 0;
    for (int i = 0; i < 5; ++i) u -= p_.balance_gain[i] * x[i];
    u = clamp(u, s(kServoRange));
    const float c = s(kFilterCoefficient);
    filtered_ = c * filtered_ + (1 - c) * u;
    return filtered_;
  }
  swing_target_ = clamp(swing_target_ + swing_rate() * s(kPeriodS), s(kArmLimitRad));
  return clamp(swing_target_, s(kServoRange));
}

float SwingUp::swing_rate() const {
  const float w0 = s(kNaturalFrequency);
  const float rate = rate_ / w0;
  const float energy = 0.5f * rate * rate - std::cos(angle_);
  const float missing = s(kTargetEnergy) - energy;
  const float earlier_angle = -rate, earlier_rate = angle_;  // a quarter period back
  const float norm = std::hypot(earlier_angle, earlier_rate);
  const float scale = norm > 1e-12f ? (kEarlierSwingRad / norm < 1 ? kEarlierSwingRad / norm : 1.0f) : 1.0f;
  const bool pumps_left = earlier_rate * scale * w0 * std::cos(earlier_angle * scale) > 0;
  const float gain = s(kEnergyGain) * missing;
  const float pumping = (pumps_left ? -1.0f : 1.0f) * s(kSwingRate) * (gain > 1 ? 1 : (gain < -1 ? -1 : gain));
  return pumping - s(kCentringPerS) * swing_target_;
}

}  // namespace pend
