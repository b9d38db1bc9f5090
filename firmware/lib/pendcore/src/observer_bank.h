// The device's bank of observers for a learned policy (policy layout 2). Mirrors
// pendkit/device/observer_runtime.py and reads pendkit/device/observer_blob.py's section;
// tests/vectors/observed-policy-device.json holds both sides to the same inputs.
// Each candidate predicts the pendulum over a control step with its rigid-body model (RK4 in 5 ms substeps,
// the new target in force after the actuation delay) and corrects with the encoder angle compared with its
// prediction at the reading's own time; the candidate that has lately predicted the readings best is shown.
#pragma once

#include <cstddef>
#include <cstdint>

#include "controller.h"

namespace pend {

constexpr size_t kMaxObservers = 16;
constexpr size_t kMaxSubsteps = 64;          // a control step of at most 0.32 s
constexpr size_t kObserverModelFields = 11;  // pendkit.device.observer_blob.MODEL_FIELDS
constexpr size_t kObserverHeaderBytes = 20;  // candidates u16, actions seen u16, four f32
constexpr size_t kObserverCandidateBytes = 4 * (kObserverModelFields + 4);
constexpr double kSubstepS = 0.005;

// What a policy's features are made of (SI units, angles from the bottom).
struct ObservedState {
  double arm_rad = 0, pendulum_rad = 0, arm_rate = 0, pendulum_rate = 0, pendulum_accel = 0;
  double target_rad = 0, age_s = 0, since_action_s = 0;
};

class CandidateObserver {
 public:
  void load(const float* model, const float* gain, double period_s, double actuation_delay_s,
            double reading_latency_s);
  void reset(const ObservedState& state);
  // A control step's prediction in pieces, so that it can run alongside the step in real time: `begin` with
  // the step's target (a unit of the servo's range), `advance` some substeps (an acting tick's share),
  // `finish` the rest; `predict` is the three at once.
  void begin(double target_unit);
  void advance(int substeps);
  void finish();
  void predict(double target_unit) {
    begin(target_unit);
    finish();
  }
  void correct(const ObservedState& state);
  ObservedState shown(const ObservedState& state) const;
  double innovation() const { return innovation_; }

 private:
  void accelerations(const double* x, double target, double& arm, double& pendulum) const;
  void rk4(double* x, double target) const;

  double i_arm_ = 0, j_pend_ = 1, i_long_ = 0, coupling_ = 0, gravity_ = 0, b_pend_ = 0, c_arm_ = 0, kp_ = 0,
         kv_ = 0, stall_ = 0, range_ = 1, extra_ = 0;
  double gain_[4] = {};
  int steps_ = 1, switch_ = 0;
  double reading_latency_s_ = 0;
  double x_[4] = {};
  double target_ = 0, innovation_ = 0;
  double step_target_ = 0, new_target_ = 0;  // the step under way: the target in force, the one arriving
  int substep_ = 0;                          // substeps of it done
  double history_[kMaxSubsteps] = {};
  int history_count_ = 0;
};

class ObserverBank {
 public:
  // Checks the observer section at `data` (its shapes, every number finite and in range); the bytes it
  // takes, or 0 when it is malformed (nothing is loaded either way).
  static size_t check(const uint8_t* data, size_t length, uint16_t& actions_seen);
  // Loads a checked section for a control step of `period_s` (at most kMaxSubsteps substeps).
  void load(const uint8_t* data, double period_s);
  ObservedState reset(const ObservedState& state);
  // The step that `begin` started finished (its rest of the prediction), then corrected with `state`.
  ObservedState update(const ObservedState& state);
  void begin(double target_unit);  // a control step under way with this target
  void advance(int substeps);      // an acting tick's share of it
  ObservedState update(double target_unit, const ObservedState& state) {  // the step at once
    begin(target_unit);
    return update(state);
  }
  size_t count() const { return count_; }
  int substeps() const { return substeps_; }  // per control step
  int chosen() const { return chosen_; }
  double filter_coefficient() const { return filter_; }
  uint16_t actions_seen() const { return actions_seen_; }

 private:
  CandidateObserver observers_[kMaxObservers];
  double misses_[kMaxObservers] = {};
  size_t count_ = 0;
  int chosen_ = 0, substeps_ = 1;
  double forgetting_ = 1, filter_ = 0;
  uint16_t actions_seen_ = 1;
};

}  // namespace pend
