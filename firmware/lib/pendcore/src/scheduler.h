// The loop around the device's logic: the one command path, the acting and streaming periods, streaming
// on/off, the v2 echo and sequence numbers, the status. Mirrors pendkit/device/scheduler.py;
// tests/vectors/scheduler.json holds both to the same results. main.cpp only wires hardware to it.
#pragma once

#include <cstddef>
#include <cstdint>

#include "device.h"
#include "protocol.h"

namespace pend {

class Scheduler {
 public:
  Scheduler();

  // One command's bytes as they arrived; a malformed one is counted and changes nothing.
  bool receive(const char* payload, size_t length, uint32_t now_ms);

  // Whether the acting tick is due now (then call device().act(now_ms)).
  bool acting_due(uint32_t now_ms) { return acting_.due(now_ms); }
  // Whether an observation is due now: the streaming period while streaming, or one asked for.
  bool streaming_due(uint32_t now_ms);

  // The line a streaming tick publishes (v2 once the host has spoken v2, else v1); 0 if it does not fit.
  size_t observation_line(const Observation& observation, char* buffer, size_t capacity);

  // True once after the host asked for the status (`r`).
  bool take_status_request();
  // The retained status as JSON; 0 if it does not fit.
  size_t status_json(const char* firmware, const char* rig, char* buffer, size_t capacity) const;

  Device& device() { return device_; }
  const Device& device() const { return device_; }
  uint32_t rejected_commands() const { return rejected_commands_; }

 private:
  Device device_;
  Schedule acting_;
  Schedule streaming_;
  uint32_t acting_period_ms_;
  uint32_t streaming_period_ms_;
  bool streaming_on_ = true;
  bool observe_once_ = false;
  bool status_requested_ = false;
  bool host_speaks_v2_ = false;
  uint32_t observation_seq_ = 0, command_seq_ = 0, echo_host_ms_ = 0, rejected_commands_ = 0;
};

}  // namespace pend
