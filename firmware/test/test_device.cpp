// Table-driven tests of the scheduler and the safety stops.
#include <doctest/doctest.h>

#include <string>

#include "device.h"

namespace {

// A valid EMS-22A frame: position, OCF set, even parity over all 16 bits.
int64_t frame_for(int32_t position) {
  const uint32_t body = (static_cast<uint32_t>(position) << 6) | (1u << 5);
  return body | (static_cast<uint32_t>(__builtin_popcount(body)) & 1u);
}

pend::Command parse(const std::string& text) {
  pend::Command command;
  REQUIRE(pend::parse_command(text.data(), text.size(), command) == pend::ParseStatus::kOk);
  return command;
}

}  // namespace

TEST_CASE("schedule: fixed deadlines, no drift, no bursts after a stall") {
  struct Row { uint32_t now; bool due; };
  const Row rows[] = {{0, true}, {5, false}, {9, false}, {10, true}, {19, false}, {21, true}, {30, true},
                      {95, true}, {100, false}, {105, true}};
  pend::Schedule schedule(10);
  for (const Row& row : rows) {
    CAPTURE(row.now);
    CHECK(schedule.due(row.now) == row.due);
  }
}

TEST_CASE("safety: no command sequence moves the servo while over-spinning") {
  pend::Device device;
  device.apply(parse("g"), 0);
  for (uint32_t k = 0; k < 8; ++k) {
    device.stream_frame(frame_for(static_cast<int32_t>((60 * k) % 1024)), 25 * k);
  }
  REQUIRE((device.flags() & pend::kFlagOverspin) != 0);
  const int32_t held = device.servo_counts();
  const char* commands[] = {"g", "a", "b1", "b-1", "m4", "#9:g@5", "e0", "h"};
  uint32_t t = 300;
  for (const char* text : commands) {
    device.apply(parse(text), t);
    CHECK(device.act(t + 5) == held);
    t += 10;
  }
}

TEST_CASE("safety: the watchdog holds the servo when commands stop") {
  pend::Device device;
  device.apply(parse("g"), 0);
  int32_t last = device.act(10);
  for (uint32_t t = 20; t <= 150; t += 10) last = device.act(t);  // still inside the timeout
  CHECK((device.flags() & pend::kFlagWatchdog) == 0);
  const int32_t at_timeout = device.act(160);
  CHECK((device.flags() & pend::kFlagWatchdog) != 0);
  CHECK(at_timeout == last);
  CHECK(device.act(500) == last);
}

TEST_CASE("safety: the servo never leaves its counts") {
  const char* commands[] = {"g", "a", "b1", "b-1", "m2", "m4", "b0.999", "e0.99"};
  pend::Device device;
  uint32_t t = 0;
  for (int round = 0; round < 50; ++round) {
    for (const char* text : commands) {
      device.apply(parse(text), t);
      for (int k = 0; k < 7; ++k) {
        const int32_t counts = device.act(t += 10);
        CHECK(counts >= pend::kServoMinCounts);
        CHECK(counts <= pend::kServoMaxCounts);
      }
    }
  }
}

TEST_CASE("a rejected command changes nothing") {
  pend::Device device;
  device.apply(parse("g"), 0);
  pend::Command command = parse("h");
  const char* bad[] = {"b2", "bnan", "#x:g", "", "q", "o1024", "p0.1"};
  for (const char* text : bad) {
    CAPTURE(text);
    const pend::Command before = command;
    CHECK(pend::parse_command(text, std::char_traits<char>::length(text), command) != pend::ParseStatus::kOk);
    CHECK(command.kind == before.kind);
  }
  CHECK(device.act(10) == 304);
}
