// libFuzzer target: arbitrary bytes as a command through the device's one command path (the Scheduler),
// then as frames and loop times, and the observation and status formatters into buffers of every small
// size; and the same bytes as serial-console lines into the CA paste and as a whole PEM. Any crash or
// sanitizer report is a bug; so is a servo outside its range.
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "broker_tls.h"
#include "scheduler.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static pend::Scheduler scheduler;
  static uint32_t now_ms = 0;
  scheduler.receive(reinterpret_cast<const char*>(data), size, now_ms);
  char line[96];
  if (scheduler.take_status_request()) scheduler.status_json("fuzz", "r00", line, 1 + size % sizeof line);
  for (size_t i = 0; i + 2 < size && i < 24; i += 3) {
    const int64_t frame = static_cast<int64_t>(data[i]) << 8 | data[i + 1];
    now_ms += data[i + 2] % 40;
    pend::Device& device = scheduler.device();
    if (scheduler.acting_due(now_ms)) device.act(now_ms);
    const pend::Observation obs = (data[i + 2] & 1) || scheduler.streaming_due(now_ms)
        ? device.stream_frame(frame, now_ms)
        : pend::Observation{now_ms, 0, device.act(now_ms), 0, 0, 0, 0};
    scheduler.observation_line(obs, line, 1 + (data[i] % sizeof line));
    if (obs.servo_counts < pend::kServoMinCounts || obs.servo_counts > pend::kServoMaxCounts) __builtin_trap();
  }
  static pend::CaConsole console;
  const char* text = reinterpret_cast<const char*>(data);
  for (size_t start = 0, end = 0; start < size; start = end + 1) {
    for (end = start; end < size && text[end] != '\n';) ++end;
    if (console.feed(text + start, end - start, now_ms) == pend::CaCommand::kAccepted &&
        console.pem_length() > pend::kMaxCaPemBytes) {
      __builtin_trap();
    }
  }
  pend::CaInfo info;
  pend::check_ca_pem(text, size, info);
  return 0;
}
