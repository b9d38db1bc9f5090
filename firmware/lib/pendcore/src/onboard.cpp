#include "onboard.h"

#include <cfloat>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "rig_constants.h"

namespace pend {

namespace {

constexpr size_t kPolicyHeaderBytes = 16;  // layout u16, actions u16, padding u32, step s f32, tick s f32
constexpr size_t kPaperInputs = 7;
constexpr double kMaxTicksPerStep = 1000;  // pendkit.device.policy_blob.MAX_TICKS_PER_STEP
constexpr double kTwoPi = 6.283185307179586;

uint16_t read_u16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | p[1] << 8); }
float read_f32(const uint8_t* p) {
  uint32_t bits = static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 | static_cast<uint32_t>(p[2]) << 16 |
                  static_cast<uint32_t>(p[3]) << 24;
  float value;
  std::memcpy(&value, &bits, sizeof value);
  return value;
}
double clip(double value, double low, double high) { return value < low ? low : (value > high ? high : value); }

uint32_t read_u32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 | static_cast<uint32_t>(p[2]) << 16 |
         static_cast<uint32_t>(p[3]) << 24;
}

}  // namespace

bool is_chunk(const uint8_t* payload, size_t length) {
  return length >= 4 && std::memcmp(payload, "PKUP", 4) == 0;
}

void Onboard::refuse(const char* reason) {
  ++refused_;
  last_refusal_ = reason;
  received_ = total_ = 0;
}

bool Onboard::chunk(const uint8_t* payload, size_t length) {
  if (length < kChunkHeaderBytes || !is_chunk(payload, length)) {
    ++ignored_;
    return false;
  }
  const uint32_t offset = read_u32(payload + 4), total = read_u32(payload + 8);
  const size_t bytes = length - kChunkHeaderBytes;
  if (bytes == 0 || bytes > kMaxChunkBytes) {
    ++ignored_;
    return false;
  }
  if (offset == 0) {
    if (total > kMaxBlobBytes) {
      refuse(blob_status_name(BlobStatus::kTooLarge));
      return true;
    }
    received_ = 0;
    total_ = total;
  } else if (total != total_ || offset != received_ || total_ == 0) {
    ++ignored_;  // a chunk after a lost one, or of another upload: the host resumes
    return false;
  }
  if (offset + bytes > total_) {
    refuse("a chunk runs past the blob's size");
    return true;
  }
  std::memcpy(buffer_ + received_, payload + kChunkHeaderBytes, bytes);
  received_ += bytes;
  if (received_ < total_) return false;
  install();
  return true;
}

void Onboard::install() {
  uint16_t kind = 0;
  const uint8_t* payload = nullptr;
  size_t payload_length = 0;
  BlobStatus status = open_blob(buffer_, total_, kind, payload, payload_length);
  if (status == BlobStatus::kOk) {
    if (kind == static_cast<uint16_t>(ControllerKind::kSwingUp)) {
      status = parse_swing_up(payload, payload_length, params_);
      if (status == BlobStatus::kOk) runtime_.set_params(params_);
    } else if (kind == static_cast<uint16_t>(ControllerKind::kPolicy)) {
      status = install_policy(payload, payload_length);
    } else {
      refuse("this device runs swing-up controllers and policies");
      return;
    }
  }
  if (status != BlobStatus::kOk) {
    refuse(blob_status_name(status));
    return;
  }
  kind_ = static_cast<ControllerKind>(kind);
  has_controller_ = true;
  running_ = false;
  active_bytes_ = static_cast<uint32_t>(total_);
  active_crc_ = crc32(buffer_, total_);
  ++accepted_;
  received_ = total_ = 0;
}

BlobStatus Onboard::install_policy(const uint8_t* payload, size_t length) {
  if (length < kPolicyHeaderBytes) return BlobStatus::kBadLength;
  const uint16_t layout = read_u16(payload), actions = read_u16(payload + 2);
  const float period = read_f32(payload + 8), acting = read_f32(payload + 12);
  const bool shape_ok = layout == 1 ? (actions >= 2 && actions <= 16) : (layout == 2 && actions == 1);
  if (!shape_ok || !(acting > 0 && acting <= period && period < 10 && period / acting <= kMaxTicksPerStep)) {
    return BlobStatus::kBadShape;
  }
  size_t observer_bytes = 0;
  uint16_t seen = 0;
  NetworkShape expected;
  if (layout == 1) {
    expected.inputs = kPaperInputs + actions;
    expected.outputs = actions;
    expected.argmax = true;
  } else {
    if (!(period / kSubstepS < kMaxSubsteps + 0.5)) return BlobStatus::kBadShape;
    observer_bytes = ObserverBank::check(payload + kPolicyHeaderBytes, length - kPolicyHeaderBytes, seen);
    if (observer_bytes == 0) return BlobStatus::kBadShape;
    expected.inputs = 2 * kPaperInputs + seen;
    expected.outputs = 1;
    expected.argmax = false;
  }
  const size_t network_at = kPolicyHeaderBytes + observer_bytes;
  const BlobStatus status = policy_.load_payload(payload + network_at, length - network_at,
                                                 static_cast<uint16_t>(ControllerKind::kNetwork), &expected);
  if (status != BlobStatus::kOk) return status;
  if (layout == 2) bank_.load(payload + kPolicyHeaderBytes, period);
  layout_ = layout;
  actions_ = actions;
  period_s_ = period;
  const long ticks = std::lround(period / acting);
  ticks_per_step_ = ticks < 1 ? 1 : static_cast<int>(ticks);
  substeps_per_tick_ = (bank_.substeps() + ticks_per_step_ - 1) / ticks_per_step_;
  return BlobStatus::kOk;
}

namespace {

// A double as the nearest float, a finite one beyond float's range as float's largest (NaN stays NaN).
float narrow(double value) {
  return value > FLT_MAX ? FLT_MAX : (value < -FLT_MAX ? -FLT_MAX : static_cast<float>(value));
}

// The kit's "paper" features of a state (pendkit.features.PAPER_FEATURES), each clipped to its bounds.
void paper_features(const ObservedState& s, float* out) {
  double from_upright = std::fmod(s.pendulum_rad, kTwoPi);
  from_upright = (from_upright < 0 ? from_upright + kTwoPi : from_upright) - kTwoPi / 2;
  out[0] = narrow(clip(from_upright, -kTwoPi / 2, kTwoPi / 2));
  out[1] = narrow(clip(s.arm_rad, -kTwoPi / 4, kTwoPi / 4));
  out[2] = narrow(s.pendulum_rate);
  out[3] = narrow(s.pendulum_accel);
  out[4] = narrow(s.arm_rate);
  out[5] = narrow(clip(s.since_action_s, 0.0, 1e30));
  out[6] = narrow(clip(s.age_s, 0.0, 1e30));
}

}  // namespace

size_t Onboard::observed_inputs(const Observation& newest, uint32_t now_ms, float* out) {
  const double rad_per_count = 2 * kServoRangeRad / kServoSpanCounts;
  ObservedState measured;
  measured.pendulum_rad = newest.position_counts * (kTwoPi / kEncoderCounts);
  measured.arm_rad = (newest.servo_counts - kServoCentreCounts) * rad_per_count;
  measured.pendulum_rate = newest.omega_rev_s * kTwoPi;
  measured.pendulum_accel = newest.accel_rev_s2 * kTwoPi;
  measured.arm_rate = newest.arm_velocity_counts_s * rad_per_count;
  measured.target_rad = measured.arm_rad;  // a hobby servo reports no position: the arm is its command
  measured.age_s = static_cast<double>(static_cast<int64_t>(now_ms) - static_cast<int64_t>(newest.millis)) / 1000.0;
  measured.since_action_s = static_cast<double>(period_s_);
  ObservedState shown;
  if (!started_) {
    shown = bank_.reset(measured);
    started_ = true;
    target_unit_ = measured.target_rad / kServoRangeRad;
  } else {
    shown = bank_.update(measured);  // the step's prediction, begun at the last decision, finished
  }
  paper_features(shown, out);
  paper_features(measured, out + kPaperInputs);
  const size_t seen = bank_.actions_seen();
  for (size_t i = 0; i < seen; ++i) out[2 * kPaperInputs + i] = recent_[i];
  return 2 * kPaperInputs + seen;
}

size_t Onboard::policy_inputs(const Observation& newest, uint32_t now_ms, float* out, size_t capacity) const {
  const size_t count = kPaperInputs + actions_;
  if (capacity < count) return 0;
  const double rad_per_count = 2 * kServoRangeRad / kServoSpanCounts;
  const double angle = newest.position_counts * (kTwoPi / kEncoderCounts);
  const double from_upright = std::fmod(angle, kTwoPi) - kTwoPi / 2;
  const double values[kPaperInputs] = {
      clip(from_upright, -kTwoPi / 2, kTwoPi / 2),
      clip((newest.servo_counts - kServoCentreCounts) * rad_per_count, -kTwoPi / 4, kTwoPi / 4),
      newest.omega_rev_s * kTwoPi,
      newest.accel_rev_s2 * kTwoPi,
      newest.arm_velocity_counts_s * rad_per_count,
      static_cast<double>(period_s_),
      clip(static_cast<double>(static_cast<int64_t>(now_ms) - static_cast<int64_t>(newest.millis)) / 1000.0, 0.0, 1e9),
  };
  for (size_t i = 0; i < kPaperInputs; ++i) out[i] = static_cast<float>(values[i]);
  for (size_t a = 0; a < actions_; ++a) out[kPaperInputs + a] = static_cast<int>(a) == last_action_ ? 1.0f : 0.0f;
  return count;
}

bool Onboard::policy_tick(const Observation* newest, uint32_t now_ms, PolicyDecision& decision) {
  if (++tick_count_ < ticks_per_step_ || newest == nullptr) {
    if (layout_ == 2 && started_) bank_.advance(substeps_per_tick_);  // a share of the step's prediction
    return false;
  }
  tick_count_ = 0;
  last_input_count_ = layout_ == 2 ? observed_inputs(*newest, now_ms, last_inputs_)
                                   : policy_inputs(*newest, now_ms, last_inputs_, kMaxPolicyInputs);
  const StepResult result = policy_.step(last_inputs_, last_input_count_);
  if (layout_ == 2 && !(result.ok && std::isfinite(result.value))) {
    bank_.begin(target_unit_);  // diverged observers: the servo holds its target, the prediction goes on
    return false;
  }
  if (!result.ok) return false;
  if (layout_ == 2) {
    const double action = clip(static_cast<double>(result.value), -1.0, 1.0);
    for (size_t i = bank_.actions_seen() - 1; i > 0; --i) recent_[i] = recent_[i - 1];
    recent_[0] = static_cast<float>(action);
    const double c = bank_.filter_coefficient();
    target_unit_ = c * target_unit_ + (1 - c) * action;
    bank_.begin(target_unit_);  // the coming step's prediction, run a share each acting tick
    decision.continuous = true;
    decision.target_unit = static_cast<float>(target_unit_);
    return true;
  }
  if (result.action < 0) return false;
  last_action_ = result.action;
  decision.continuous = false;
  decision.action = result.action;
  return true;
}

bool Onboard::policy_tick(const Observation* newest, uint32_t now_ms, int& action) {
  PolicyDecision decision;
  if (!policy_tick(newest, now_ms, decision) || decision.continuous) return false;
  action = decision.action;
  return true;
}

bool Onboard::start(float pendulum_rad, float target_rad) {
  if (!has_controller_) return false;
  if (kind_ == ControllerKind::kPolicy) {
    policy_.reset();
    last_action_ = 0;
    tick_count_ = ticks_per_step_ - 1;  // the first tick decides
    started_ = false;
    target_unit_ = 0.0;
    for (float& value : recent_) value = 0.0f;
  } else {
    runtime_.reset(pendulum_rad, target_rad);
  }
  running_ = true;
  return true;
}

size_t Onboard::status_json(char* buffer, size_t capacity) const {
  const int length = std::snprintf(
      buffer, capacity,
      "{\"kind\":%s,\"bytes\":%lu,\"crc\":%lu,\"running\":%s,\"received\":%lu,\"total\":%lu,\"accepted\":%lu,"
      "\"refused\":%lu,\"ignored_chunks\":%lu,\"last_refusal\":\"%s\"}",
      kind_ == ControllerKind::kPolicy ? "\"policy\"" : (has_controller_ ? "\"swing-up\"" : "null"), static_cast<unsigned long>(active_bytes_),
      static_cast<unsigned long>(active_crc_), running_ ? "true" : "false", static_cast<unsigned long>(received_),
      static_cast<unsigned long>(total_), static_cast<unsigned long>(accepted_), static_cast<unsigned long>(refused_),
      static_cast<unsigned long>(ignored_), last_refusal_);
  return (length < 0 || static_cast<size_t>(length) >= capacity) ? 0 : static_cast<size_t>(length);
}

}  // namespace pend
