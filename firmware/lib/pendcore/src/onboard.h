// A controller the device runs itself: its upload in chunks, the active one, whether it runs. Mirrors
// pendkit/device/onboard.py; tests/vectors/uploads.json holds both to the same outcomes.
//   chunk := "PKUP" | offset u32 | blob size u32 | up to 1024 bytes of the blob   (little-endian)
// An upload starts at offset 0; a chunk that does not start where the device has got to is ignored and
// counted (the host resumes from `received`). The whole blob is checked before it replaces the active
// controller; a refused one is counted and changes nothing.
#pragma once

#include <cstddef>
#include <cstdint>

#include "controller.h"
#include "observer_bank.h"
#include "protocol.h"
#include "swingup.h"

namespace pend {

constexpr size_t kMaxChunkBytes = 1024;
constexpr size_t kChunkHeaderBytes = 12;
constexpr size_t kMaxPolicyInputs = 32;

// What a policy decided on a control step: an action index (layout 1) or a target (layout 2, a unit of the
// servo's range, already through the policy's own filter).
struct PolicyDecision {
  bool continuous = false;
  int action = 0;
  float target_unit = 0.0f;
};

bool is_chunk(const uint8_t* payload, size_t length);

class Onboard {
 public:
  // Takes one chunk; true when an upload ended with it (accepted or refused).
  bool chunk(const uint8_t* payload, size_t length);
  bool start(float pendulum_rad, float target_rad);  // false: no controller to run
  void stop() { running_ = false; }
  bool running() const { return running_; }
  float tick(float pendulum_rad, float target_in_force_rad) { return runtime_.tick(pendulum_rad, target_in_force_rad); }
  bool runs_policy() const { return kind_ == ControllerKind::kPolicy; }
  // A policy's acting tick: true (and the decision) when a control step decides, from the newest reading.
  bool policy_tick(const Observation* newest, uint32_t now_ms, PolicyDecision& decision);
  bool policy_tick(const Observation* newest, uint32_t now_ms, int& action);  // layout 1's action alone
  // Layout 1's inputs from a reading (pendkit.device.policy_blob); `count` floats written.
  size_t policy_inputs(const Observation& newest, uint32_t now_ms, float* out, size_t capacity) const;
  // The inputs the last decision was made from (either layout), and how many.
  const float* last_inputs(size_t& count) const {
    count = last_input_count_;
    return last_inputs_;
  }
  const ObserverBank& observers() const { return bank_; }
  // Layout 2: take `action` and `target_unit` as the last decision's. A replay of recorded decisions (the
  // shared vectors) stays on the recording with it: a float's last bit, fed back through the observers and
  // the GRU, grows over an episode.
  void follow(float action, double target_unit) {
    recent_[0] = action;
    target_unit_ = target_unit;
    bank_.begin(target_unit);  // the step's prediction starts again with it
  }
  const SwingUp& runtime() const { return runtime_; }
  // The status's "controller" object as JSON; 0 if it does not fit.
  size_t status_json(char* buffer, size_t capacity) const;

 private:
  void refuse(const char* reason);
  void install();
  BlobStatus install_policy(const uint8_t* payload, size_t length);
  size_t observed_inputs(const Observation& newest, uint32_t now_ms, float* out);  // layout 2: moves the observers

  uint8_t buffer_[kMaxBlobBytes];
  size_t received_ = 0, total_ = 0;
  SwingUpParams params_;  // scratch for a checked blob, copied into the runtime when accepted
  SwingUp runtime_;
  Controller policy_;  // a policy's network (71 KB)
  ObserverBank bank_;  // layout 2's observers (about 10 KB)
  uint16_t layout_ = 1, actions_ = 0;
  bool started_ = false;  // layout 2: the observers have taken their first reading
  float recent_[8] = {};  // layout 2: the last actions, the newest first
  double target_unit_ = 0.0;  // layout 2: the target after the policy's filter
  float last_inputs_[kMaxPolicyInputs] = {};
  size_t last_input_count_ = 0;
  float period_s_ = 0.06f;
  int ticks_per_step_ = 6, tick_count_ = 0, last_action_ = 0;
  int substeps_per_tick_ = 2;  // layout 2: the observers' prediction runs alongside the step, a share a tick
  ControllerKind kind_ = ControllerKind::kNone;
  bool has_controller_ = false, running_ = false;
  uint32_t active_bytes_ = 0, active_crc_ = 0, accepted_ = 0, refused_ = 0, ignored_ = 0;
  const char* last_refusal_ = "";
};

}  // namespace pend
