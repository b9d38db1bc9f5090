// Commands (v1 and v2) and observation lines: the grammar of pendkit.device.commands / protocol.
#pragma once

#include <cstddef>
#include <cstdint>

namespace pend {

constexpr size_t kMaxCommandLength = 64;

enum class ParseStatus : uint8_t { kOk, kEmpty, kTooLong, kBadFraming, kUnknownCommand, kBadNumber, kOutOfRange };

enum class CommandKind : uint8_t {
  kAction, kTarget, kEncoderOffset, kStreamingPeriod, kActingPeriod, kFilter, kObserveOnce, kStreamOn,
  kStreamOff, kContinuousMode, kDiscreteMode, kHeartbeat, kStatus, kWatchdogTimeout, kOverspinLimit,
  kSetVelocityWindow, kOnboard,
};

struct Command {
  CommandKind kind = CommandKind::kHeartbeat;
  double value = 0.0;  // the action index for kAction
  bool has_seq = false;
  uint32_t seq = 0;
  bool has_host_ms = false;
  uint32_t host_ms = 0;
};

const char* parse_status_name(ParseStatus status);   // "ok", "empty", ... as in the vectors
const char* command_kind_name(CommandKind kind);      // "action", "target", ...

// Parses `length` bytes (no terminator needed). On failure `out` is left untouched.
ParseStatus parse_command(const char* text, size_t length, Command& out);

struct Observation {
  uint32_t millis;
  int32_t position_counts;
  int32_t servo_counts;
  double omega_rev_s;
  double accel_rev_s2;
  double arm_velocity_counts_s;
  uint8_t flags;
};

// Writes a NUL-terminated line into buffer; returns its length, or 0 if it does not fit.
size_t format_observation_v1(const Observation& obs, char* buffer, size_t capacity);
size_t format_observation_v2(const Observation& obs, uint32_t observation_seq, uint32_t command_seq,
                             uint32_t echo_host_ms, char* buffer, size_t capacity);

}  // namespace pend
