// The shared vectors (written from the Python reference): the core must give the same answers.
#include <doctest/doctest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "device.h"
#include "encoder.h"
#include "protocol.h"
#include "scheduler.h"

using nlohmann::json;

namespace {

json load(const std::string& name) {
  std::ifstream file(std::string(VECTORS_DIR) + "/" + name);
  REQUIRE_MESSAGE(file.good(), "cannot open vector file " << name);
  return json::parse(file);
}

std::string from_hex(const std::string& hex) {  // an upload chunk written as hex in a scenario
  std::string bytes;
  for (size_t i = 0; i + 1 < hex.size(); i += 2) bytes.push_back(static_cast<char>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  return bytes;
}

}  // namespace

TEST_CASE("encoder frames: status and position") {
  const json vectors = load("encoder_frames.json");
  for (const json& c : vectors["cases"]) {
    const int64_t frame = c["frame"].get<int64_t>();
    CAPTURE(frame);
    const pend::FrameStatus status = pend::frame_status(frame);
    CHECK(std::string(pend::frame_status_name(status)) == c["status"].get<std::string>());
    if (status == pend::FrameStatus::kOk) {
      CHECK(pend::frame_position(static_cast<uint32_t>(frame)) == c["position_counts"].get<int>());
    }
  }
}

TEST_CASE("wrap-aware deltas") {
  const json vectors = load("wrap_delta.json");
  for (const json& c : vectors["cases"]) {
    CAPTURE(c.dump());
    CHECK(pend::wrap_delta(c["new"].get<int>(), c["old"].get<int>(), vectors["counts"].get<int>()) ==
          c["delta"].get<int>());
  }
}

TEST_CASE("velocity estimator") {
  const json vectors = load("velocity.json");
  const double tolerance = vectors["tolerance"].get<double>();
  for (const json& sequence : vectors["sequences"]) {
    CAPTURE(sequence["name"].get<std::string>());
    pend::VelocityEstimator estimator(vectors["window"].get<int>(), vectors["counts"].get<int>());
    for (size_t k = 0; k < sequence["positions"].size(); ++k) {
      const pend::Estimate e = estimator.update(sequence["positions"][k].get<int>(),
                                                static_cast<uint32_t>(sequence["times_ms"][k].get<double>()));
      CAPTURE(k);
      CHECK(e.omega_rev_s == doctest::Approx(sequence["omega_rev_s"][k].get<double>()).epsilon(tolerance));
      CHECK(std::fabs(e.accel_rev_s2 - sequence["accel_rev_s2"][k].get<double>()) <= tolerance);
    }
  }
}

TEST_CASE("command grammar") {
  const json vectors = load("commands.json");
  for (const json& c : vectors["cases"]) {
    const std::string text = c["text"].get<std::string>();
    CAPTURE(text);
    pend::Command command;
    const pend::ParseStatus status = pend::parse_command(text.data(), text.size(), command);
    REQUIRE(std::string(pend::parse_status_name(status)) == c["status"].get<std::string>());
    if (status != pend::ParseStatus::kOk) continue;
    CHECK(std::string(pend::command_kind_name(command.kind)) == c["kind"].get<std::string>());
    CHECK(command.value == c["value"].get<double>());
    CHECK(command.has_seq == !c["seq"].is_null());
    if (command.has_seq) CHECK(command.seq == c["seq"].get<uint32_t>());
    CHECK(command.has_host_ms == !c["host_ms"].is_null());
    if (command.has_host_ms) CHECK(command.host_ms == c["host_ms"].get<uint32_t>());
  }
}

TEST_CASE("observation lines, v1 and v2") {
  const json vectors = load("observations.json");
  for (const json& c : vectors["cases"]) {
    const pend::Observation obs{c["millis"].get<uint32_t>(), c["position"].get<int32_t>(), c["servo"].get<int32_t>(),
                                c["omega"].get<double>(), c["accel"].get<double>(), c["arm_velocity"].get<double>(),
                                c["flags"].get<uint8_t>()};
    char line[128];
    REQUIRE(pend::format_observation_v1(obs, line, sizeof line) > 0);
    CHECK(std::string(line) == c["v1"].get<std::string>());
    REQUIRE(pend::format_observation_v2(obs, c["obs_seq"].get<uint32_t>(), c["cmd_seq"].get<uint32_t>(),
                                        c["echo_ms"].get<uint32_t>(), line, sizeof line) > 0);
    CHECK(std::string(line) == c["v2"].get<std::string>());
    CHECK(pend::format_observation_v1(obs, line, 8) == 0);  // too small: refused, never truncated silently
  }
}

TEST_CASE("device scenarios") {
  const json vectors = load("device.json");
  const double tolerance = vectors["tolerance"].get<double>();
  for (const json& scenario : vectors["scenarios"]) {
    const std::string name = scenario["name"].get<std::string>();
    pend::Device device;
    REQUIRE(device.servo_counts() == vectors["servo_start"].get<int>());
    const json& events = scenario["events"];
    const json& expected = scenario["expected"];
    for (size_t k = 0; k < events.size(); ++k) {
      CAPTURE(name);
      CAPTURE(k);
      const json& event = events[k];
      const json& want = expected[k];
      const uint32_t t = event["t"].get<uint32_t>();
      if (event.contains("cmd")) {
        const std::string text = event["cmd"].get<std::string>();
        pend::Command command;
        const pend::ParseStatus status = pend::parse_command(text.data(), text.size(), command);
        CHECK(std::string(pend::parse_status_name(status)) == want["status"].get<std::string>());
        if (status == pend::ParseStatus::kOk) device.apply(command, t);
      } else if (event.contains("act")) {
        CHECK(device.act(t) == want["servo"].get<int>());
        CHECK((device.flags() & 15) == want["flags"].get<int>());
      } else {
        const pend::Observation obs = device.stream_frame(event["frame"].get<int64_t>(), t);
        CHECK(obs.position_counts == want["position"].get<int>());
        CHECK(obs.servo_counts == want["servo"].get<int>());
        CHECK(std::fabs(obs.omega_rev_s - want["omega"].get<double>()) <= tolerance);
        CHECK(std::fabs(obs.accel_rev_s2 - want["accel"].get<double>()) <= tolerance);
        CHECK(std::fabs(obs.arm_velocity_counts_s - want["arm_velocity"].get<double>()) <= tolerance);
        CHECK(obs.flags == want["flags"].get<int>());
      }
    }
  }
}

TEST_CASE("the device's loop: scheduler scenarios") {
  const json vectors = load("scheduler.json");
  for (const json& scenario : vectors["scenarios"]) {
    CAPTURE(scenario["name"].get<std::string>());
    pend::Scheduler scheduler;
    std::vector<json> records;
    const json& commands = scenario["commands"];
    size_t next_command = 0;
    for (const json& loop_ms : scenario["loop_ms"]) {
      const uint32_t now = loop_ms.get<uint32_t>();
      while (next_command < commands.size() && commands[next_command][0].get<uint32_t>() <= now) {
        const std::string text = commands[next_command++][1].get<std::string>();
        const std::string sent = text.rfind("hex:", 0) == 0 ? from_hex(text.substr(4)) : text;  // an upload chunk
        records.push_back({{"t", now}, {"cmd", text}, {"taken", scheduler.receive(sent.data(), sent.size(), now)}});
      }
      char buffer[640];
      if (scheduler.take_status_request()) {
        REQUIRE(scheduler.status_json("test", "r00", buffer, sizeof buffer) > 0);
        json status = json::parse(buffer);
        CHECK(status["firmware"] == "test");
        CHECK(status["rig"] == "r00");
        status.erase("firmware");
        status.erase("rig");
        records.push_back({{"t", now}, {"status", status}});
      }
      // the encoder read at the acting tick: the same pendulum as the frames, a count every 3 ms
      const int32_t raw = static_cast<int32_t>((now / 3) % 1024);
      if (scheduler.acting_due(now)) records.push_back({{"t", now}, {"act", scheduler.device().act(now, raw)}});
      if (scheduler.streaming_due(now)) {
        const json& want = scenario["records"].at(records.size());  // it names the encoder frame read now
        const int64_t frame = want.value("frame", int64_t{0});
        const pend::Observation observation = scheduler.device().stream_frame(frame, now);
        REQUIRE(scheduler.observation_line(observation, buffer, sizeof buffer) > 0);
        records.push_back({{"t", now}, {"frame", frame}, {"line", std::string(buffer)}});
      }
    }
    const json& expected = scenario["records"];
    REQUIRE(records.size() == expected.size());
    for (size_t k = 0; k < records.size(); ++k) {
      CAPTURE(k);
      CHECK(records[k] == expected[k]);
    }
  }
}
