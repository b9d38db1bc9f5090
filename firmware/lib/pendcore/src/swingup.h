// The device's swing-up controller (blob kind 3), line for line pendkit/device/swingup_runtime.py: every
// acting tick it folds in the encoder reading (a two-state filter predicting with gravity, damping and
// the arm's push) and advances the servo-and-arm model; every control step it follows the plan from rest
// (when there is one and the pendulum starts at rest), settles with the plan's LQR, pumps energy, or
// balances with the LQR and its action filter. Floats only (the S2 has no FPU: no double work here).
#pragma once

#include <cstddef>
#include <cstdint>

namespace pend {

constexpr size_t kMaxPlanSteps = 200;

enum Scalar : uint8_t {
  kPeriodS, kActingPeriodS, kObserverAngleGain, kObserverRateGain, kNaturalFrequency, kEnergyGain, kSwingRate,
  kCentringPerS, kArmLimitRad, kTargetEnergy, kCatchAngle, kCatchVelocity, kFallAngle, kFilterCoefficient,
  kServoRange, kRestAngle, kRestVelocity, kDriftRad, kServoKpPerInertia, kServoKvPerInertia,
  kArmDampingPerInertia, kStallPerInertia, kCouplingPerInertia, kPendulumDampingPerInertia, kScalarCount,
};

struct SwingUpParams {
  float scalar[kScalarCount] = {};
  float balance_gain[5] = {};
  float settle_gain[5] = {};
  uint16_t plan_steps = 0, settle_steps = 0, warmup_steps = 0;
  float plan_target[kMaxPlanSteps] = {};
  float plan_state[kMaxPlanSteps][5] = {};
  float plan_gain[kMaxPlanSteps][5] = {};
};

enum class SwingMode : uint8_t { kWait, kTrack, kSettle, kSwing, kBalance };
const char* swing_mode_name(SwingMode mode);

class SwingUp {
 public:
  void set_params(const SwingUpParams& params);
  const SwingUpParams& params() const { return p_; }
  void reset(float pendulum_rad, float target_rad);
  // One acting tick: the encoder's angle from the bottom and the target in force -> the target to hold.
  float tick(float pendulum_rad, float target_in_force_rad);
  SwingMode mode() const { return mode_; }
  float angle_rad() const { return angle_; }
  float rate_rad_s() const { return rate_; }

 private:
  void observe(float pendulum_rad, float target_in_force_rad);
  float arm_acceleration(float target_rad) const;
  float control_step();
  SwingMode first_mode() const;
  bool track(float& target);
  bool settle(float& target);
  float swing_or_balance();
  float swing_rate() const;
  float s(Scalar name) const { return p_.scalar[name]; }

  SwingUpParams p_;
  int ticks_per_step_ = 1;
  float angle_ = 0, rate_ = 0, arm_ = 0, arm_rate_ = 0, output_ = 0, swing_target_ = 0, filtered_ = 0;
  float servo_sees_ = 0;  // the target the servo drives to this tick: the one in force a tick back
  SwingMode mode_ = SwingMode::kSwing;
  int tick_count_ = 0;
  uint32_t steps_ = 0, plan_step_ = 0;
};

}  // namespace pend
