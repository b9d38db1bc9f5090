#include "controller.h"

#include "rig_constants.h"
#include "swingup.h"

#include <cmath>
#include <cstring>
#include <initializer_list>

namespace pend {

static_assert(sizeof kSwingUpScalarMin / sizeof kSwingUpScalarMin[0] == kScalarCount,
              "rig_constants.h's swing-up ranges are pendkit.device.swingup_blob.SCALARS'");

namespace {

constexpr uint8_t kMagic[4] = {'P', 'K', 'C', 'B'};
constexpr uint16_t kVersion = 1;
constexpr size_t kHeaderBytes = 12;  // magic, version u16, kind u16, payload bytes u32
constexpr size_t kCrcBytes = 4;

uint16_t read_u16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | p[1] << 8); }
uint32_t read_u32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 | static_cast<uint32_t>(p[2]) << 16 |
         static_cast<uint32_t>(p[3]) << 24;
}
float read_f32(const uint8_t* p) {
  const uint32_t bits = read_u32(p);
  float value;
  std::memcpy(&value, &bits, sizeof value);
  return value;
}

// Walks a payload: every take is bounds-checked; `fail` remembers the first problem.
struct Walker {
  const uint8_t* data;
  size_t length;
  size_t at = 0;
  BlobStatus fail = BlobStatus::kOk;

  const uint8_t* take(size_t bytes) {
    if (fail != BlobStatus::kOk || bytes > length - at) {
      if (fail == BlobStatus::kOk) fail = BlobStatus::kBadLength;
      return nullptr;
    }
    const uint8_t* p = data + at;
    at += bytes;
    return p;
  }
  const uint8_t* floats(size_t count) {  // finite float32s
    if (count > kMaxBlobBytes / 4) {
      fail = BlobStatus::kBadLength;
      return nullptr;
    }
    const uint8_t* p = take(4 * count);
    for (size_t i = 0; p != nullptr && i < count; ++i) {
      if (!std::isfinite(read_f32(p + 4 * i))) {
        fail = BlobStatus::kNotFinite;
        return nullptr;
      }
    }
    return p;
  }
};

float sigmoid(float x) { return 1.0f / (1.0f + std::exp(-x)); }

float activate(Activation activation, float x) {
  switch (activation) {
    case Activation::kRelu: return x > 0.0f ? x : 0.0f;
    case Activation::kTanh: return std::tanh(x);
    case Activation::kSigmoid: return sigmoid(x);
    default: return x;
  }
}

}  // namespace

const char* blob_status_name(BlobStatus status) {
  switch (status) {
    case BlobStatus::kOk: return "ok";
    case BlobStatus::kTooShort: return "too short";
    case BlobStatus::kTooLarge: return "too large";
    case BlobStatus::kBadMagic: return "bad magic";
    case BlobStatus::kBadVersion: return "bad version";
    case BlobStatus::kBadLength: return "bad length";
    case BlobStatus::kBadCrc: return "bad crc";
    case BlobStatus::kBadShape: return "bad shape";
    case BlobStatus::kNotFinite: return "not finite";
    case BlobStatus::kUnknownKind: return "unknown kind";
    case BlobStatus::kTrailingBytes: return "trailing bytes";
  }
  return "?";
}

uint32_t crc32(const uint8_t* data, size_t length) {  // zlib's CRC-32 (reflected 0xEDB88320)
  uint32_t crc = 0xFFFFFFFFu;
  for (size_t i = 0; i < length; ++i) {
    crc ^= data[i];
    for (int bit = 0; bit < 8; ++bit) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

BlobStatus open_blob(const uint8_t* blob, size_t length, uint16_t& kind, const uint8_t*& payload,
                     size_t& payload_length) {
  if (length > kMaxBlobBytes) return BlobStatus::kTooLarge;
  if (blob == nullptr || length < kHeaderBytes + kCrcBytes) return BlobStatus::kTooShort;
  if (std::memcmp(blob, kMagic, 4) != 0) return BlobStatus::kBadMagic;
  if (read_u16(blob + 4) != kVersion) return BlobStatus::kBadVersion;
  const uint32_t size = read_u32(blob + 8);
  if (static_cast<size_t>(size) != length - kHeaderBytes - kCrcBytes) return BlobStatus::kBadLength;
  if (crc32(blob, length - kCrcBytes) != read_u32(blob + length - kCrcBytes)) return BlobStatus::kBadCrc;
  kind = read_u16(blob + 6);
  payload = blob + kHeaderBytes;
  payload_length = size;
  return BlobStatus::kOk;
}

BlobStatus parse_swing_up(const uint8_t* payload, size_t length, SwingUpParams& out) {
  Walker w{payload, length};
  const uint8_t* head = w.take(8);
  if (head == nullptr) return w.fail;
  const uint16_t steps = read_u16(head), settle = read_u16(head + 2), warmup = read_u16(head + 4);
  if (steps > kMaxPlanSteps || settle > 1000 || warmup > 100) return BlobStatus::kBadShape;
  const uint8_t* scalars = w.floats(kScalarCount);
  const uint8_t* balance = w.floats(5);
  const uint8_t* settle_gain = w.floats(5);
  const uint8_t* targets = w.floats(steps);
  const uint8_t* states = w.floats(5u * steps);
  const uint8_t* gains = w.floats(5u * steps);
  if (w.fail != BlobStatus::kOk) return w.fail;
  if (w.at != length) return BlobStatus::kTrailingBytes;
  float value[kScalarCount];
  for (size_t i = 0; i < kScalarCount; ++i) value[i] = read_f32(scalars + 4 * i);
  for (Scalar name : {kPeriodS, kActingPeriodS, kNaturalFrequency, kServoRange, kArmLimitRad, kServoKpPerInertia,
                      kStallPerInertia}) {
    if (!(value[name] > 0.0f)) return BlobStatus::kBadShape;
  }
  if (value[kPeriodS] < value[kActingPeriodS] || !(value[kFilterCoefficient] >= 0.0f && value[kFilterCoefficient] < 1.0f)) {
    return BlobStatus::kBadShape;
  }
  for (size_t i = 0; i < kScalarCount; ++i) {  // the model's terms in their physical ranges, as the Python parser
    if (!(value[i] >= kSwingUpScalarMin[i] && value[i] <= kSwingUpScalarMax[i])) return BlobStatus::kBadShape;
  }
  for (size_t i = 0; i < kScalarCount; ++i) out.scalar[i] = value[i];
  for (size_t i = 0; i < 5; ++i) {
    out.balance_gain[i] = read_f32(balance + 4 * i);
    out.settle_gain[i] = read_f32(settle_gain + 4 * i);
  }
  for (size_t k = 0; k < steps; ++k) {
    out.plan_target[k] = read_f32(targets + 4 * k);
    for (size_t i = 0; i < 5; ++i) {
      out.plan_state[k][i] = read_f32(states + 4 * (5 * k + i));
      out.plan_gain[k][i] = read_f32(gains + 4 * (5 * k + i));
    }
  }
  out.plan_steps = steps;
  out.settle_steps = settle;
  out.warmup_steps = warmup;
  return BlobStatus::kOk;
}

BlobStatus Controller::load(const uint8_t* blob, size_t length) {
  uint16_t kind = 0;
  const uint8_t* payload = nullptr;
  size_t payload_length = 0;
  const BlobStatus status = open_blob(blob, length, kind, payload, payload_length);
  return status == BlobStatus::kOk ? load_payload(payload, payload_length, kind) : status;
}

BlobStatus Controller::load_payload(const uint8_t* payload, size_t length, uint16_t kind, const NetworkShape* expected) {
  NetworkShape shape;
  const BlobStatus status = check(payload, length, kind, &shape);
  if (status != BlobStatus::kOk) return status;
  if (expected != nullptr && (shape.inputs != expected->inputs || shape.outputs != expected->outputs ||
                              shape.argmax != expected->argmax)) {
    return BlobStatus::kBadShape;
  }
  copy(payload, kind);
  return BlobStatus::kOk;
}

// Validates the whole payload without touching the active controller.
BlobStatus Controller::check(const uint8_t* payload, size_t length, uint16_t kind, NetworkShape* found) const {
  Walker w{payload, length};
  if (kind == static_cast<uint16_t>(ControllerKind::kStateFeedback)) {
    const uint8_t* head = w.take(4);
    if (head == nullptr) return w.fail;
    const uint16_t size = read_u16(head);
    if (size == 0 || size > kMaxStateSize) return BlobStatus::kBadShape;
    w.floats(size);
    w.floats(size);
    const uint8_t* limit = w.floats(1);
    if (limit != nullptr && !(read_f32(limit) > 0.0f)) return BlobStatus::kBadShape;
  } else if (kind == static_cast<uint16_t>(ControllerKind::kNetwork)) {
    const uint8_t* head = w.take(8);
    if (head == nullptr) return w.fail;
    const uint16_t inputs = read_u16(head), gru = read_u16(head + 2), layers = read_u16(head + 4);
    const uint8_t output = head[6];
    if (inputs == 0 || inputs > kMaxWidth || gru > kMaxWidth || layers == 0 || layers > kMaxLayers || output > 1) {
      return BlobStatus::kBadShape;
    }
    w.floats(inputs);
    const uint8_t* scales = w.floats(inputs);
    for (size_t i = 0; scales != nullptr && i < inputs; ++i) {
      if (!(read_f32(scales + 4 * i) > 0.0f)) return BlobStatus::kBadShape;
    }
    const uint8_t* clip = w.floats(1);
    if (clip != nullptr && !(read_f32(clip) > 0.0f)) return BlobStatus::kBadShape;
    if (gru > 0) {
      w.floats(3u * gru * inputs);
      w.floats(3u * gru * gru);
      w.floats(3u * gru);
      w.floats(3u * gru);
    }
    size_t width = static_cast<size_t>(inputs) + gru;
    for (uint16_t k = 0; k < layers && w.fail == BlobStatus::kOk; ++k) {
      const uint8_t* shape = w.take(6);  // rows u16, cols u16, activation u8, padding u8
      if (shape == nullptr) break;
      const uint16_t rows = read_u16(shape), cols = read_u16(shape + 2);
      if (cols != width || rows == 0 || rows > kMaxWidth || shape[4] > 3) return BlobStatus::kBadShape;
      w.floats(static_cast<size_t>(rows) * cols);
      w.floats(rows);
      width = rows;
    }
    if (found != nullptr) {
      found->inputs = inputs;
      found->outputs = width;
      found->argmax = output == 0;
    }
  } else {
    return BlobStatus::kUnknownKind;
  }
  if (w.fail != BlobStatus::kOk) return w.fail;
  return w.at == length ? BlobStatus::kOk : BlobStatus::kTrailingBytes;
}

// Copies a checked payload into the arena (little-endian floats, copied whatever the host's alignment).
void Controller::copy(const uint8_t* payload, uint16_t kind) {
  used_ = 0;
  size_t at = 0;
  auto floats = [&](size_t count) {
    float* out = arena_ + used_;
    for (size_t i = 0; i < count; ++i) out[i] = read_f32(payload + at + 4 * i);
    at += 4 * count;
    used_ += count;
    return static_cast<const float*>(out);
  };
  kind_ = static_cast<ControllerKind>(kind);
  if (kind_ == ControllerKind::kStateFeedback) {
    state_size_ = read_u16(payload);
    at = 4;
    gain_ = floats(state_size_);
    reference_ = floats(state_size_);
    output_limit_ = *floats(1);
    return;
  }
  input_size_ = read_u16(payload);
  gru_size_ = read_u16(payload + 2);
  layer_count_ = read_u16(payload + 4);
  argmax_ = payload[6] == 0;
  at = 8;
  mean_ = floats(input_size_);
  std_ = floats(input_size_);
  clip_ = *floats(1);
  const size_t gates = 3u * gru_size_;
  if (gru_size_ > 0) {
    w_ih_ = floats(gates * input_size_);
    w_hh_ = floats(gates * gru_size_);
    b_ih_ = floats(gates);
    b_hh_ = floats(gates);
  }
  for (uint16_t k = 0; k < layer_count_; ++k) {
    Dense& layer = layers_[k];
    layer.rows = read_u16(payload + at);
    layer.cols = read_u16(payload + at + 2);
    layer.activation = static_cast<Activation>(payload[at + 4]);
    at += 6;
    layer.weight = floats(static_cast<size_t>(layer.rows) * layer.cols);
    layer.bias = floats(layer.rows);
  }
  reset();
}

void Controller::reset() {
  for (size_t i = 0; i < kMaxWidth; ++i) hidden_[i] = 0.0f;
}

size_t Controller::output_size() const {
  if (kind_ == ControllerKind::kStateFeedback) return 1;
  return kind_ == ControllerKind::kNetwork ? layers_[layer_count_ - 1].rows : 0;
}

size_t Controller::multiply_accumulates() const {
  if (kind_ == ControllerKind::kStateFeedback) return state_size_;
  size_t macs = 3u * gru_size_ * (input_size_ + gru_size_);
  for (uint16_t k = 0; k < layer_count_; ++k) macs += static_cast<size_t>(layers_[k].rows) * layers_[k].cols;
  return macs;
}

StepResult Controller::step(const float* inputs, size_t count, float* outputs, size_t capacity) {
  StepResult result;
  if (kind_ == ControllerKind::kStateFeedback) {
    if (count != state_size_) return result;
    float u = 0.0f;
    for (size_t i = 0; i < state_size_; ++i) u -= gain_[i] * (inputs[i] - reference_[i]);
    result.value = u > output_limit_ ? output_limit_ : (u < -output_limit_ ? -output_limit_ : u);
    result.ok = true;
    if (outputs != nullptr && capacity >= 1) outputs[0] = result.value;
    return result;
  }
  if (kind_ != ControllerKind::kNetwork || count != input_size_) return result;
  float* z = buffer_a_;  // [normalised input, new GRU state]
  for (size_t i = 0; i < input_size_; ++i) {
    const float v = (inputs[i] - mean_[i]) / std_[i];
    z[i] = v > clip_ ? clip_ : (v < -clip_ ? -clip_ : v);
  }
  const size_t n = gru_size_;
  if (n > 0) {
    float* gates = buffer_b_;  // r, u, and the candidate's input and hidden parts
    for (size_t g = 0; g < 3 * n; ++g) {
      float gi = b_ih_[g], gh = b_hh_[g];
      for (size_t j = 0; j < input_size_; ++j) gi += w_ih_[g * input_size_ + j] * z[j];
      for (size_t j = 0; j < n; ++j) gh += w_hh_[g * n + j] * hidden_[j];
      if (g < 2 * n) {
        gates[g] = sigmoid(gi + gh);
      } else {
        gates[g] = gi;
        gates[g + n] = gh;
      }
    }
    for (size_t j = 0; j < n; ++j) {
      const float candidate = std::tanh(gates[2 * n + j] + gates[j] * gates[3 * n + j]);
      hidden_[j] = (1.0f - gates[n + j]) * candidate + gates[n + j] * hidden_[j];
      z[input_size_ + j] = hidden_[j];
    }
  }
  float* in = z;
  float* out = buffer_b_;
  for (uint16_t k = 0; k < layer_count_; ++k) {
    const Dense& layer = layers_[k];
    for (size_t r = 0; r < layer.rows; ++r) {
      float sum = layer.bias[r];
      for (size_t c = 0; c < layer.cols; ++c) sum += layer.weight[r * layer.cols + c] * in[c];
      out[r] = activate(layer.activation, sum);
    }
    float* swap = in;
    in = out;
    out = swap;
  }
  const size_t size = layers_[layer_count_ - 1].rows;
  for (size_t i = 0; outputs != nullptr && i < size && i < capacity; ++i) outputs[i] = in[i];
  if (argmax_) {
    size_t best = 0;
    for (size_t i = 1; i < size; ++i) best = in[i] > in[best] ? i : best;
    result.action = static_cast<int>(best);
  } else {
    result.value = in[0];
  }
  result.ok = true;
  return result;
}

}  // namespace pend
