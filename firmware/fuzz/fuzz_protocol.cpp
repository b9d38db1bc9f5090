// libFuzzer target: arbitrary bytes as a command, then as frames and ticks for the device, and the
// observation formatter into buffers of every small size. Any crash or sanitizer report is a bug.
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "device.h"
#include "protocol.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static pend::Device device;
  static uint32_t now_ms = 0;
  pend::Command command;
  if (pend::parse_command(reinterpret_cast<const char*>(data), size, command) == pend::ParseStatus::kOk) {
    device.handle(command, now_ms);
  }
  for (size_t i = 0; i + 2 < size && i < 24; i += 3) {
    const int64_t frame = static_cast<int64_t>(data[i]) << 8 | data[i + 1];
    now_ms += data[i + 2] % 40;
    const pend::Observation obs = (data[i + 2] & 1) ? device.stream_frame(frame, now_ms)
                                                    : pend::Observation{now_ms, 0, device.act(now_ms), 0, 0, 0, 0};
    char line[96];
    const size_t capacity = 1 + (data[i] % sizeof line);
    pend::format_observation_v1(obs, line, capacity);
    pend::format_observation_v2(obs, data[i], data[i + 1], now_ms, line, capacity);
    if (obs.servo_counts < pend::kServoMinCounts || obs.servo_counts > pend::kServoMaxCounts) __builtin_trap();
  }
  return 0;
}
