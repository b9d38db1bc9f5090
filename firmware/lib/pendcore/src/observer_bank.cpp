#include "observer_bank.h"

#include <cmath>
#include <cstring>
#include <initializer_list>

#include "rig_constants.h"

namespace pend {

static_assert(sizeof kObserverModelMin / sizeof kObserverModelMin[0] == kObserverModelFields,
              "rig_constants.h's observer ranges are pendkit.device.observer_blob.MODEL_FIELDS'");

namespace {

constexpr double kPi = 3.141592653589793;
constexpr double kTwoPi = 6.283185307179586;

uint16_t read_u16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | p[1] << 8); }
float read_f32(const uint8_t* p) {
  const uint32_t bits = static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 |
                        static_cast<uint32_t>(p[2]) << 16 | static_cast<uint32_t>(p[3]) << 24;
  float value;
  std::memcpy(&value, &bits, sizeof value);
  return value;
}

// Each model term in its physical range and a mass matrix positive at every pendulum angle, as the Python
// parser checks them (pendkit/device/physical_ranges.py): a pendulum of 1e-38 kg m^2 is refused, not divided by.
bool physically_possible(const uint8_t* model) {
  double value[kObserverModelFields];
  for (size_t i = 0; i < kObserverModelFields; ++i) {
    value[i] = read_f32(model + 4 * i);
    if (!(value[i] >= kObserverModelMin[i] && value[i] <= kObserverModelMax[i])) return false;
  }
  const double arm = value[0], pendulum = value[1], long_axis = value[2], coupling = value[3];
  return arm * pendulum > coupling * coupling && arm + pendulum > long_axis;
}

// Python's floored modulo (the result takes the divisor's sign).
double floored_mod(double value, double by) {
  const double m = std::fmod(value, by);
  return m < 0 ? m + by : m;
}
int round_half_up(double value) { return static_cast<int>(std::floor(value + 0.5)); }

}  // namespace

void CandidateObserver::load(const float* m, const float* gain, double period_s, double actuation_delay_s,
                             double reading_latency_s) {
  i_arm_ = m[0];
  j_pend_ = m[1];
  i_long_ = m[2];
  coupling_ = m[3];
  gravity_ = m[4];
  b_pend_ = m[5];
  c_arm_ = m[6];
  kp_ = m[7];
  kv_ = m[8];
  stall_ = m[9];
  range_ = m[10];
  extra_ = j_pend_ - i_long_;
  for (int i = 0; i < 4; ++i) gain_[i] = gain[i];
  const int steps = round_half_up(period_s / kSubstepS);
  steps_ = steps < 1 ? 1 : (steps > static_cast<int>(kMaxSubsteps) ? static_cast<int>(kMaxSubsteps) : steps);
  switch_ = round_half_up(actuation_delay_s / kSubstepS);
  reading_latency_s_ = reading_latency_s;
}

void CandidateObserver::reset(const ObservedState& state) {
  x_[0] = state.arm_rad;
  x_[1] = state.pendulum_rad;
  x_[2] = state.arm_rate;
  x_[3] = state.pendulum_rate;
  target_ = state.target_rad;
  history_count_ = 0;
}

void CandidateObserver::accelerations(const double* x, double target, double& arm, double& pendulum) const {
  const double phi = x[0], alpha = x[1], phi_dot = x[2], alpha_dot = x[3];
  const double s = std::sin(alpha), c = std::cos(alpha);
  const double m_arm = i_arm_ + extra_ * s * s, m_cross = coupling_ * c;
  const double drive = kp_ * (target - phi) - kv_ * phi_dot;
  const double torque = drive < -stall_ ? -stall_ : (drive > stall_ ? stall_ : drive);
  const double rhs_arm = (torque - c_arm_ * phi_dot - 2 * extra_ * s * c * phi_dot * alpha_dot +
                          coupling_ * s * alpha_dot * alpha_dot);
  const double rhs_pend = extra_ * s * c * phi_dot * phi_dot - gravity_ * s - b_pend_ * alpha_dot;
  const double det = m_arm * j_pend_ - m_cross * m_cross;
  arm = (j_pend_ * rhs_arm - m_cross * rhs_pend) / det;
  pendulum = (m_arm * rhs_pend - m_cross * rhs_arm) / det;
}

void CandidateObserver::rk4(double* x, double target) const {
  const double dt = kSubstepS;
  double k[4][4], probe[4];
  for (int stage = 0; stage < 4; ++stage) {
    const double by = stage == 0 ? 0.0 : (stage == 3 ? dt : dt / 2);
    for (int i = 0; i < 4; ++i) probe[i] = stage == 0 ? x[i] : x[i] + by * k[stage - 1][i];
    k[stage][0] = probe[2];
    k[stage][1] = probe[3];
    accelerations(probe, target, k[stage][2], k[stage][3]);
  }
  for (int i = 0; i < 4; ++i) x[i] = x[i] + dt / 6 * (k[0][i] + 2 * k[1][i] + 2 * k[2][i] + k[3][i]);
}

void CandidateObserver::begin(double target_unit) {
  new_target_ = target_unit * range_;
  step_target_ = target_;
  substep_ = 0;
  history_count_ = 0;
}

void CandidateObserver::advance(int substeps) {
  const double limit = range_;
  for (int done = 0; done < substeps && substep_ < steps_; ++done, ++substep_) {
    if (substep_ == switch_) step_target_ = new_target_;
    rk4(x_, step_target_);
    step_target_ = step_target_ < -limit ? -limit : (step_target_ > limit ? limit : step_target_);
    history_[history_count_++] = x_[1];
  }
}

void CandidateObserver::finish() {
  advance(steps_ - substep_);
  target_ = switch_ >= steps_ ? new_target_ : step_target_;
}

void CandidateObserver::correct(const ObservedState& state) {
  const double age_s = state.age_s + reading_latency_s_;
  double predicted = x_[1];
  if (history_count_ > 0) {  // the substep nearest the reading's moment (the older one on a tie)
    const int last = history_count_ - 1;
    int nearest = 0;
    double best = std::fabs(last * kSubstepS - age_s);
    for (int k = 1; k <= last; ++k) {
      const double miss = std::fabs((last - k) * kSubstepS - age_s);
      if (miss < best) {
        best = miss;
        nearest = k;
      }
    }
    predicted = history_[nearest];
  }
  const double innovation = floored_mod(state.pendulum_rad - predicted + kPi, kTwoPi) - kPi;
  for (int i = 0; i < 4; ++i) x_[i] = x_[i] + gain_[i] * innovation;
  innovation_ = innovation;
}

ObservedState CandidateObserver::shown(const ObservedState& state) const {
  ObservedState out = state;
  double unused, pendulum_accel;
  accelerations(x_, target_, unused, pendulum_accel);
  out.arm_rad = x_[0];
  out.pendulum_rad = floored_mod(x_[1], kTwoPi);
  out.arm_rate = x_[2];
  out.pendulum_rate = x_[3];
  out.pendulum_accel = pendulum_accel;
  return out;
}

size_t ObserverBank::check(const uint8_t* data, size_t length, uint16_t& actions_seen) {
  if (length < kObserverHeaderBytes) return 0;
  const uint16_t count = read_u16(data), seen = read_u16(data + 2);
  const double actuation = read_f32(data + 4), reading = read_f32(data + 8), forgetting = read_f32(data + 12),
               filter = read_f32(data + 16);
  if (count < 1 || count > kMaxObservers || seen < 1 || seen > 8) return 0;
  if (!(actuation >= 0 && actuation < 1 && reading >= 0 && reading < 1 && forgetting > 0 && forgetting <= 1 &&
        filter >= 0 && filter < 1)) {
    return 0;  // also every NaN
  }
  const size_t bytes = kObserverHeaderBytes + count * kObserverCandidateBytes;
  if (length < bytes) return 0;
  for (size_t c = 0; c < count; ++c) {
    const uint8_t* at = data + kObserverHeaderBytes + c * kObserverCandidateBytes;
    for (size_t i = 0; i < kObserverModelFields + 4; ++i) {
      if (!std::isfinite(read_f32(at + 4 * i))) return 0;
    }
    for (size_t i : {0u, 1u, 2u, 4u, 9u, 10u}) {  // inertias, gravity torque, stall torque, range
      if (!(read_f32(at + 4 * i) > 0)) return 0;
    }
    if (!physically_possible(at)) return 0;
  }
  actions_seen = seen;
  return bytes;
}

void ObserverBank::load(const uint8_t* data, double period_s) {
  count_ = read_u16(data);
  actions_seen_ = read_u16(data + 2);
  const double actuation = read_f32(data + 4), reading = read_f32(data + 8);
  forgetting_ = read_f32(data + 12);
  filter_ = read_f32(data + 16);
  float model[kObserverModelFields], gain[4];
  for (size_t c = 0; c < count_; ++c) {
    const uint8_t* at = data + kObserverHeaderBytes + c * kObserverCandidateBytes;
    for (size_t i = 0; i < kObserverModelFields; ++i) model[i] = read_f32(at + 4 * i);
    for (size_t i = 0; i < 4; ++i) gain[i] = read_f32(at + 4 * (kObserverModelFields + i));
    observers_[c].load(model, gain, period_s, actuation, reading);
  }
  const int steps = round_half_up(period_s / kSubstepS);
  substeps_ = steps < 1 ? 1 : (steps > static_cast<int>(kMaxSubsteps) ? static_cast<int>(kMaxSubsteps) : steps);
  chosen_ = 0;
}

ObservedState ObserverBank::reset(const ObservedState& state) {
  for (size_t c = 0; c < count_; ++c) {
    observers_[c].reset(state);
    misses_[c] = 0;
  }
  chosen_ = 0;
  return observers_[0].shown(state);
}

void ObserverBank::begin(double target_unit) {
  for (size_t c = 0; c < count_; ++c) observers_[c].begin(target_unit);
}

void ObserverBank::advance(int substeps) {
  for (size_t c = 0; c < count_; ++c) observers_[c].advance(substeps);
}

ObservedState ObserverBank::update(const ObservedState& state) {
  chosen_ = 0;
  for (size_t c = 0; c < count_; ++c) {
    observers_[c].finish();
    observers_[c].correct(state);
    const double squared = observers_[c].innovation() * observers_[c].innovation();
    misses_[c] += forgetting_ * (squared - misses_[c]);
    if (misses_[c] < misses_[chosen_]) chosen_ = static_cast<int>(c);
  }
  return observers_[chosen_].shown(state);
}

}  // namespace pend
