#include "protocol.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace pend {
namespace {

bool is_digit(char c) { return c >= '0' && c <= '9'; }

// Decimal digits only, 1..10 of them, value <= 2^32 - 1.
bool parse_uint32(const char* text, size_t length, uint32_t& out) {
  if (length == 0 || length > 10) return false;
  uint64_t value = 0;
  for (size_t i = 0; i < length; ++i) {
    if (!is_digit(text[i])) return false;
    value = value * 10 + static_cast<uint64_t>(text[i] - '0');
  }
  if (value > 0xFFFFFFFFull) return false;
  out = static_cast<uint32_t>(value);
  return true;
}

// [+-]?[0-9]+ and at most 11 characters.
bool parse_integer(const char* text, size_t length, double& out) {
  if (length == 0 || length > 11) return false;
  size_t i = (text[0] == '+' || text[0] == '-') ? 1 : 0;
  if (i == length) return false;
  int64_t value = 0;
  for (size_t k = i; k < length; ++k) {
    if (!is_digit(text[k])) return false;
    value = value * 10 + (text[k] - '0');
  }
  out = static_cast<double>(text[0] == '-' ? -value : value);
  return true;
}

// [+-]?([0-9]+(.[0-9]*)?|.[0-9]+), at most 16 characters; converted with strtod (correctly rounded).
bool parse_decimal(const char* text, size_t length, double& out) {
  if (length == 0 || length > 16) return false;
  size_t i = (text[0] == '+' || text[0] == '-') ? 1 : 0;
  size_t before = 0, after = 0;
  while (i < length && is_digit(text[i])) { ++i; ++before; }
  if (i < length && text[i] == '.') {
    ++i;
    while (i < length && is_digit(text[i])) { ++i; ++after; }
  }
  if (i != length || (before == 0 && after == 0)) return false;
  char copy[17];
  std::memcpy(copy, text, length);
  copy[length] = '\0';
  out = std::strtod(copy, nullptr);
  return true;
}

struct Range {
  char letter;
  CommandKind kind;
  double low, high;
  bool integer;
};

constexpr Range kSettings[] = {
    {'o', CommandKind::kEncoderOffset, 0, 1023, true},  {'u', CommandKind::kStreamingPeriod, 5, 1000, true},
    {'i', CommandKind::kActingPeriod, 5, 1000, true},   {'w', CommandKind::kWatchdogTimeout, 50, 5000, true},
    {'m', CommandKind::kAction, 0, 4, true},            {'b', CommandKind::kTarget, -1.0, 1.0, false},
    {'e', CommandKind::kFilter, 0.0, 0.999, false},     {'p', CommandKind::kOverspinLimit, 0.0, 20.0, false},
    {'n', CommandKind::kSetVelocityWindow, 1, 16, true}, {'k', CommandKind::kOnboard, 0, 1, true},
};

bool single_letter(char letter, CommandKind& kind, double& value) {
  switch (letter) {
    case 'a': kind = CommandKind::kAction; value = 2; return true;  // fast left
    case 's': kind = CommandKind::kAction; value = 1; return true;  // slow left
    case 'd': kind = CommandKind::kAction; value = 0; return true;  // stop
    case 'f': kind = CommandKind::kAction; value = 3; return true;  // slow right
    case 'g': kind = CommandKind::kAction; value = 4; return true;  // fast right
    case 'z': kind = CommandKind::kObserveOnce; return true;
    case 'x': kind = CommandKind::kStreamOn; return true;
    case 'y': kind = CommandKind::kStreamOff; return true;
    case 'c': kind = CommandKind::kContinuousMode; return true;
    case 'v': kind = CommandKind::kDiscreteMode; return true;
    case 'h': kind = CommandKind::kHeartbeat; return true;
    case 'r': kind = CommandKind::kStatus; return true;
    default: return false;
  }
}

}  // namespace

const char* parse_status_name(ParseStatus status) {
  switch (status) {
    case ParseStatus::kOk: return "ok";
    case ParseStatus::kEmpty: return "empty";
    case ParseStatus::kTooLong: return "too_long";
    case ParseStatus::kBadFraming: return "bad_framing";
    case ParseStatus::kUnknownCommand: return "unknown_command";
    case ParseStatus::kBadNumber: return "bad_number";
    case ParseStatus::kOutOfRange: return "out_of_range";
  }
  return "unknown";
}

const char* command_kind_name(CommandKind kind) {
  switch (kind) {
    case CommandKind::kAction: return "action";
    case CommandKind::kTarget: return "target";
    case CommandKind::kEncoderOffset: return "encoder_offset";
    case CommandKind::kStreamingPeriod: return "streaming_period";
    case CommandKind::kActingPeriod: return "acting_period";
    case CommandKind::kFilter: return "filter";
    case CommandKind::kObserveOnce: return "observe_once";
    case CommandKind::kStreamOn: return "stream_on";
    case CommandKind::kStreamOff: return "stream_off";
    case CommandKind::kContinuousMode: return "continuous_mode";
    case CommandKind::kDiscreteMode: return "discrete_mode";
    case CommandKind::kHeartbeat: return "heartbeat";
    case CommandKind::kStatus: return "status";
    case CommandKind::kWatchdogTimeout: return "watchdog_timeout";
    case CommandKind::kOverspinLimit: return "overspin_limit";
    case CommandKind::kSetVelocityWindow: return "velocity_window";
    case CommandKind::kOnboard: return "onboard";
  }
  return "unknown";
}

ParseStatus parse_command(const char* text, size_t length, Command& out) {
  if (text == nullptr) return ParseStatus::kEmpty;
  while (length > 0 && (text[length - 1] == '\r' || text[length - 1] == '\n' || text[length - 1] == ' ')) --length;
  if (length == 0) return ParseStatus::kEmpty;
  if (length > kMaxCommandLength) return ParseStatus::kTooLong;
  Command command;
  const char* body = text;
  size_t body_length = length;
  if (body[0] == '#') {
    const char* colon = static_cast<const char*>(std::memchr(body, ':', body_length));
    if (colon == nullptr) return ParseStatus::kBadFraming;
    const size_t digits = static_cast<size_t>(colon - body) - 1;
    for (size_t i = 1; i <= digits; ++i) {
      if (!is_digit(body[i])) return ParseStatus::kBadFraming;
    }
    if (!parse_uint32(body + 1, digits, command.seq)) return ParseStatus::kBadFraming;
    command.has_seq = true;
    body_length -= digits + 2;
    body = colon + 1;
  }
  const char* at = static_cast<const char*>(std::memchr(body, '@', body_length));
  if (at != nullptr) {
    const size_t stamp_length = body_length - static_cast<size_t>(at - body) - 1;
    if (!parse_uint32(at + 1, stamp_length, command.host_ms)) return ParseStatus::kBadFraming;
    command.has_host_ms = true;
    body_length = static_cast<size_t>(at - body);
  }
  if (body_length == 0) return ParseStatus::kEmpty;
  const char letter = body[0];
  const char* argument = body + 1;
  const size_t argument_length = body_length - 1;
  if (argument_length == 0 && single_letter(letter, command.kind, command.value)) {
    out = command;
    return ParseStatus::kOk;
  }
  for (const Range& range : kSettings) {
    if (range.letter != letter) continue;
    double value = 0.0;
    const bool ok = range.integer ? parse_integer(argument, argument_length, value)
                                  : parse_decimal(argument, argument_length, value);
    if (!ok) return ParseStatus::kBadNumber;
    if (range.kind == CommandKind::kOverspinLimit && value > 0 && value < 0.5) return ParseStatus::kOutOfRange;
    if (value < range.low || value > range.high) return ParseStatus::kOutOfRange;
    command.kind = range.kind;
    command.value = value;
    out = command;
    return ParseStatus::kOk;
  }
  return ParseStatus::kUnknownCommand;
}

size_t format_observation_v1(const Observation& obs, char* buffer, size_t capacity) {
  const int written = std::snprintf(buffer, capacity, "S%lu,%ld,%ld,%.4f,%.4f,%.1f",
                                    static_cast<unsigned long>(obs.millis), static_cast<long>(obs.position_counts),
                                    static_cast<long>(obs.servo_counts), obs.omega_rev_s, obs.accel_rev_s2,
                                    obs.arm_velocity_counts_s);
  return (written > 0 && static_cast<size_t>(written) < capacity) ? static_cast<size_t>(written) : 0;
}

size_t format_observation_v2(const Observation& obs, uint32_t observation_seq, uint32_t command_seq,
                             uint32_t echo_host_ms, char* buffer, size_t capacity) {
  const int written = std::snprintf(
      buffer, capacity, "R%lu,%lu,%ld,%ld,%.4f,%.4f,%.1f,%u,%lu,%lu", static_cast<unsigned long>(obs.millis),
      static_cast<unsigned long>(observation_seq), static_cast<long>(obs.position_counts),
      static_cast<long>(obs.servo_counts), obs.omega_rev_s, obs.accel_rev_s2, obs.arm_velocity_counts_s,
      static_cast<unsigned>(obs.flags), static_cast<unsigned long>(command_seq),
      static_cast<unsigned long>(echo_host_ms));
  return (written > 0 && static_cast<size_t>(written) < capacity) ? static_cast<size_t>(written) : 0;
}

}  // namespace pend
