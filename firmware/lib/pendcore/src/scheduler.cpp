#include "scheduler.h"

#include <cstdio>

namespace pend {

Scheduler::Scheduler()
    : acting_(kActingPeriodMs),
      streaming_(kStreamingPeriodMs),
      acting_period_ms_(kActingPeriodMs),
      streaming_period_ms_(kStreamingPeriodMs) {}

bool Scheduler::receive(const char* payload, size_t length, uint32_t now_ms) {
  const uint8_t* bytes = reinterpret_cast<const uint8_t*>(payload);
  if (is_chunk(bytes, length)) {  // an upload on the controller topic
    if (device_.onboard().chunk(bytes, length)) status_requested_ = true;  // an upload ended: say how
    return false;
  }
  Command command;
  if (parse_command(payload, length, command) != ParseStatus::kOk) {
    ++rejected_commands_;
    return false;
  }
  if (command.has_seq) {
    host_speaks_v2_ = true;
    command_seq_ = command.seq;
  }
  if (command.has_host_ms) echo_host_ms_ = command.host_ms;
  switch (command.kind) {
    case CommandKind::kStreamOn: streaming_on_ = true; break;
    case CommandKind::kStreamOff: streaming_on_ = false; break;
    case CommandKind::kObserveOnce: observe_once_ = true; break;
    case CommandKind::kStreamingPeriod:
      streaming_period_ms_ = static_cast<uint32_t>(command.value);
      streaming_.set_period(streaming_period_ms_);
      break;
    case CommandKind::kActingPeriod:
      acting_period_ms_ = static_cast<uint32_t>(command.value);
      acting_.set_period(acting_period_ms_);
      break;
    case CommandKind::kStatus: status_requested_ = true; break;
    default: device_.apply(command, now_ms); break;
  }
  return true;
}

bool Scheduler::streaming_due(uint32_t now_ms) {
  if ((streaming_on_ && streaming_.due(now_ms)) || observe_once_) {
    observe_once_ = false;
    return true;
  }
  return false;
}

size_t Scheduler::observation_line(const Observation& observation, char* buffer, size_t capacity) {
  const size_t length = host_speaks_v2_
      ? format_observation_v2(observation, observation_seq_, command_seq_, echo_host_ms_, buffer, capacity)
      : format_observation_v1(observation, buffer, capacity);
  ++observation_seq_;  // every observation takes the next number, also one that did not fit
  return length;
}

bool Scheduler::take_status_request() {
  const bool requested = status_requested_;
  status_requested_ = false;
  return requested;
}

size_t Scheduler::status_json(const char* firmware, const char* rig, char* buffer, size_t capacity) const {
  const int length = std::snprintf(
      buffer, capacity,
      "{\"firmware\":\"%s\",\"protocol\":2,\"rig\":\"%s\",\"streaming_ms\":%lu,\"acting_ms\":%lu,"
      "\"mode\":\"%s\",\"online\":true,\"flags\":%u,\"rejected_commands\":%lu,\"servo_counts_range\":[%ld,%ld],"
      "\"controller\":",
      firmware, rig, static_cast<unsigned long>(streaming_period_ms_), static_cast<unsigned long>(acting_period_ms_),
      device_.discrete() ? "discrete" : "continuous", static_cast<unsigned>(device_.flags() & 15u),
      static_cast<unsigned long>(rejected_commands_), static_cast<long>(kServoMinCounts),
      static_cast<long>(kServoMaxCounts));
  if (length < 0 || static_cast<size_t>(length) >= capacity) return 0;
  const size_t used = static_cast<size_t>(length);
  const size_t inner = device_.onboard().status_json(buffer + used, capacity - used);
  if (inner == 0 || used + inner + 2 > capacity) return 0;
  buffer[used + inner] = '}';
  buffer[used + inner + 1] = '\0';
  return used + inner + 1;
}

}  // namespace pend
