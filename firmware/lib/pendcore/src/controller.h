// A controller the device runs itself, loaded from a blob (pendkit.device.controller_blob: the same bytes):
// a network (input normalisation, a GRU cell, dense layers with ReLU/tanh/sigmoid, argmax or a continuous
// output) or state feedback. No heap: the weights live in the controller's own arena. A blob is checked
// whole (length, magic, version, CRC32, every shape, every number finite) before anything is copied, so a
// bad, partial or oversized one changes nothing. Errors are values.
#pragma once

#include <cstddef>
#include <cstdint>

namespace pend {

constexpr size_t kMaxBlobBytes = 64 * 1024;  // a fifth of the ESP32-S2's SRAM; the shipped R-DQN is 47 KB
constexpr size_t kMaxWidth = 256;
constexpr size_t kMaxLayers = 8;
constexpr size_t kMaxStateSize = 16;

enum class BlobStatus : uint8_t {
  kOk, kTooShort, kTooLarge, kBadMagic, kBadVersion, kBadLength, kBadCrc, kBadShape, kNotFinite, kUnknownKind,
  kTrailingBytes,
};
enum class ControllerKind : uint8_t { kNone = 0, kNetwork = 1, kStateFeedback = 2, kSwingUp = 3, kPolicy = 4 };
enum class Activation : uint8_t { kNone = 0, kRelu = 1, kTanh = 2, kSigmoid = 3 };

const char* blob_status_name(BlobStatus status);
uint32_t crc32(const uint8_t* data, size_t length);

// Checks a blob's envelope (length, magic, version, CRC); on kOk names its kind and payload.
BlobStatus open_blob(const uint8_t* blob, size_t length, uint16_t& kind, const uint8_t*& payload,
                     size_t& payload_length);

struct SwingUpParams;
// Reads a swing-up payload (kind 3, pendkit.device.swingup_blob) into `out`, checking every shape and number.
BlobStatus parse_swing_up(const uint8_t* payload, size_t length, SwingUpParams& out);

struct StepResult {
  bool ok = false;       // false: no controller loaded, or inputs of the wrong size
  int action = -1;       // argmax networks
  float value = 0.0f;    // continuous networks and state feedback
};

struct NetworkShape {
  size_t inputs = 0, outputs = 0;
  bool argmax = true;
};

class Controller {
 public:
  // Replaces the active controller with the blob's, or returns why not (the active one stays).
  BlobStatus load(const uint8_t* blob, size_t length);
  // The same from a payload already taken out of its envelope (a policy's network); `expected`, when given,
  // is the shape the caller needs: another shape is refused before anything is copied.
  BlobStatus load_payload(const uint8_t* payload, size_t length, uint16_t kind, const NetworkShape* expected = nullptr);
  void reset();  // an episode's start: the GRU state to zero
  // One control step; `outputs` (capacity `capacity`) receives the last layer (Q-values), if given.
  StepResult step(const float* inputs, size_t count, float* outputs = nullptr, size_t capacity = 0);

  ControllerKind kind() const { return kind_; }
  size_t input_size() const { return kind_ == ControllerKind::kStateFeedback ? state_size_ : input_size_; }
  size_t output_size() const;
  size_t weight_count() const { return used_; }
  size_t multiply_accumulates() const;  // per step

 private:
  struct Dense {
    uint16_t rows = 0, cols = 0;
    Activation activation = Activation::kNone;
    const float* weight = nullptr;
    const float* bias = nullptr;
  };
  BlobStatus check(const uint8_t* payload, size_t length, uint16_t kind, NetworkShape* found = nullptr) const;
  void copy(const uint8_t* payload, uint16_t kind);

  ControllerKind kind_ = ControllerKind::kNone;
  uint16_t input_size_ = 0, gru_size_ = 0, layer_count_ = 0, state_size_ = 0;
  bool argmax_ = true;
  float clip_ = 0.0f, output_limit_ = 0.0f;
  const float *mean_ = nullptr, *std_ = nullptr, *w_ih_ = nullptr, *w_hh_ = nullptr, *b_ih_ = nullptr,
              *b_hh_ = nullptr, *gain_ = nullptr, *reference_ = nullptr;
  Dense layers_[kMaxLayers];
  size_t used_ = 0;
  float arena_[kMaxBlobBytes / 4];
  float hidden_[kMaxWidth] = {};
  float buffer_a_[2 * kMaxWidth] = {};
  float buffer_b_[4 * kMaxWidth] = {};  // the GRU's gates, then a layer's outputs
};

}  // namespace pend
