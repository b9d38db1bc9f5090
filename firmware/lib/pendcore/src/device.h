// The device's logic with time passed in: commands, the acting and streaming ticks, safety stops.
// Mirrors pendkit/device/logic.py; tests/vectors/device.json holds both to the same results.
#pragma once

#include <cstdint>

#include "encoder.h"
#include "onboard.h"
#include "protocol.h"
#include "rig_constants.h"

namespace pend {

enum Flag : uint8_t {
  kFlagArmLimit = 1,
  kFlagOverspin = 2,
  kFlagStuckEncoder = 4,
  kFlagWatchdog = 8,
  kFlagFrameError = 16,  // this observation repeats the last good reading
};

class Device {
 public:
  Device();
  void reset(int32_t servo_counts, uint32_t now_ms);

  // The one entry for a decoded command: actions and settings (scheduling commands are the Scheduler's).
  void apply(const Command& command, uint32_t now_ms);

  // Acting tick: advance the target (by the command, or by the running onboard controller from the encoder
  // read now: `raw_counts`, -1 when not read), apply the safety stops last, return the counts to actuate.
  int32_t act(uint32_t now_ms, int32_t raw_counts = -1);

  Onboard& onboard() { return onboard_; }
  const Onboard& onboard() const { return onboard_; }

  // Streaming tick from a raw SSI frame; a bad frame repeats the last good reading.
  Observation stream_frame(int64_t frame, uint32_t now_ms);

  int32_t servo_counts() const { return servo_counts_; }
  uint8_t flags() const { return flags_; }
  bool discrete() const { return discrete_; }

 private:
  Observation stream_raw(int32_t raw_counts, uint32_t now_ms, bool frame_error);
  float pendulum_rad(int32_t raw_counts) const;
  float servo_rad(int32_t counts) const;
  void set(uint8_t flag, bool on) { flags_ = on ? (flags_ | flag) : (flags_ & static_cast<uint8_t>(~flag)); }

  VelocityEstimator estimator_;
  int32_t offset_counts_ = kEncoderOffsetCounts;
  double watchdog_timeout_ms_ = kWatchdogTimeoutMs;
  double overspin_limit_rev_s_ = kOverspinLimitRevS;
  double device_filter_ = 0.0;  // the kit filters on the host; `e<c>` restores the authors' device filter
  bool discrete_ = true;
  bool onboard_was_running_ = false;  // to hold the servo when the onboard controller stops
  int32_t increment_counts_ = 0;
  double target_unit_ = 0.0;
  double filtered_unit_ = 0.0;
  int32_t servo_counts_ = 0;
  uint32_t last_command_ms_ = 0;
  int32_t last_stream_servo_ = 0;
  uint32_t last_stream_ms_ = 0;
  bool has_raw_ = false;
  int32_t last_raw_ = 0;
  int32_t bad_frames_ = 0;
  int32_t servo_at_last_change_ = 0;
  uint8_t flags_ = 0;
  bool has_observation_ = false;
  Observation last_observation_{};  // the newest reading: a policy's inputs come from it
  Onboard onboard_;  // kept across resets, as in RAM
};

// Fixed-rate deadlines for the two ticks; a late loop catches up by skipping, never by bursting.
class Schedule {
 public:
  explicit Schedule(uint32_t period_ms, uint32_t start_ms = 0) : period_ms_(period_ms), next_ms_(start_ms) {}
  bool due(uint32_t now_ms);
  void set_period(uint32_t period_ms) { period_ms_ = period_ms; }

 private:
  uint32_t period_ms_;
  uint32_t next_ms_;
};

}  // namespace pend
