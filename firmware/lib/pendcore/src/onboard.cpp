#include "onboard.h"

#include <cmath>
#include <cstdio>
#include <cstring>

#include "rig_constants.h"

namespace pend {

namespace {

constexpr size_t kPolicyHeaderBytes = 16;  // layout u16, actions u16, padding u32, step s f32, tick s f32
constexpr size_t kPaperInputs = 7;
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
  if (layout != 1 || actions < 2 || actions > 16 || !(acting > 0 && acting <= period && period < 10)) {
    return BlobStatus::kBadShape;
  }
  NetworkShape expected;
  expected.inputs = kPaperInputs + actions;
  expected.outputs = actions;
  expected.argmax = true;
  const BlobStatus status = policy_.load_payload(payload + kPolicyHeaderBytes, length - kPolicyHeaderBytes,
                                                 static_cast<uint16_t>(ControllerKind::kNetwork), &expected);
  if (status != BlobStatus::kOk) return status;
  actions_ = actions;
  period_s_ = period;
  const long ticks = std::lround(period / acting);
  ticks_per_step_ = ticks < 1 ? 1 : static_cast<int>(ticks);
  return BlobStatus::kOk;
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

bool Onboard::policy_tick(const Observation* newest, uint32_t now_ms, int& action) {
  if (++tick_count_ < ticks_per_step_ || newest == nullptr) return false;
  tick_count_ = 0;
  float inputs[kPaperInputs + 16];
  const size_t count = policy_inputs(*newest, now_ms, inputs, sizeof inputs / sizeof inputs[0]);
  const StepResult result = policy_.step(inputs, count);
  if (!result.ok || result.action < 0) return false;
  last_action_ = result.action;
  action = result.action;
  return true;
}

bool Onboard::start(float pendulum_rad, float target_rad) {
  if (!has_controller_) return false;
  if (kind_ == ControllerKind::kPolicy) {
    policy_.reset();
    last_action_ = 0;
    tick_count_ = ticks_per_step_ - 1;  // the first tick decides
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
