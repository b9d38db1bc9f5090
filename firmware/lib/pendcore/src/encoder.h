// EMS-22A SSI frames, wrap-aware differences and the velocity estimator (pendkit.encoder's definitions).
#pragma once

#include <cstdint>

#include "rig_constants.h"

namespace pend {

enum class FrameStatus : uint8_t {
  kOk,
  kFrameWidth,
  kParity,
  kOffsetCompensationNotFinished,
  kCordicOverflow,
  kLinearityAlarm,
  kMagnetOutOfRange,
};

// Names as in the shared vectors ("ok", "parity", ...).
const char* frame_status_name(FrameStatus status);

// Checks in a fixed order: width, even parity, OCF set, COF clear, LIN clear, not both magnet bits.
FrameStatus frame_status(int64_t frame);

// Position bits 15..6 of a frame (meaningful only when frame_status() is kOk).
inline int32_t frame_position(uint32_t frame) { return static_cast<int32_t>((frame >> 6) & 0x3FF); }

// new - old the shorter way round; a jump of exactly half a turn keeps its sign.
int32_t wrap_delta(int32_t new_counts, int32_t old_counts, int32_t counts = kEncoderCounts);

struct Estimate {
  double omega_rev_s;
  double accel_rev_s2;
};

// Mean of the last `window` velocities (buffer starts at zeros); acceleration from the last two means.
class VelocityEstimator {
 public:
  static constexpr int kMaxWindow = 64;
  explicit VelocityEstimator(int window = kVelocityWindow, int32_t counts = kEncoderCounts);
  void reset();
  Estimate update(int32_t position, uint32_t now_ms);

 private:
  int window_;
  int32_t counts_;
  double ring_[kMaxWindow];
  int index_;
  bool has_last_;
  int32_t last_position_;
  uint32_t last_time_ms_;
  double last_mean_;
};

}  // namespace pend
