// The device's own swing-up and its uploads against the shared vectors written by
// tests/vectors/make_onboard_vectors.py: every acting tick's inputs and the Python runtime's outputs, and
// upload scenarios with the controller status after each chunk.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "onboard.h"
#include "swingup.h"
#include "vector_files.h"

using json = nlohmann::json;

namespace {

std::vector<uint8_t> from_hex(const std::string& hex) {
  std::vector<uint8_t> out;
  for (size_t i = 0; i + 1 < hex.size(); i += 2) {
    out.push_back(static_cast<uint8_t>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  }
  return out;
}

pend::Onboard onboard;  // 82 KB: static, as on the device
pend::SwingUpParams params;
pend::SwingUp runtime;

// A blob sent to `onboard` as the laptop does: PKUP chunks of at most kMaxChunkBytes, offset and total size.
void upload(const std::vector<uint8_t>& blob) {
  for (size_t offset = 0; offset < blob.size(); offset += pend::kMaxChunkBytes) {
    const size_t bytes = std::min(pend::kMaxChunkBytes, blob.size() - offset);
    std::vector<uint8_t> chunk = {'P', 'K', 'U', 'P'};
    for (int i = 0; i < 4; ++i) chunk.push_back(static_cast<uint8_t>(offset >> (8 * i)));
    for (int i = 0; i < 4; ++i) chunk.push_back(static_cast<uint8_t>(blob.size() >> (8 * i)));
    chunk.insert(chunk.end(), blob.begin() + static_cast<long>(offset), blob.begin() + static_cast<long>(offset + bytes));
    onboard.chunk(chunk.data(), chunk.size());
  }
}

void replay(const std::string& name) {
  const std::vector<uint8_t> blob = read_vector_file("swing-up-" + name + ".pkcb");
  uint16_t kind = 0;
  const uint8_t* payload = nullptr;
  size_t length = 0;
  REQUIRE(pend::open_blob(blob.data(), blob.size(), kind, payload, length) == pend::BlobStatus::kOk);
  REQUIRE(kind == 3);
  REQUIRE(pend::parse_swing_up(payload, length, params) == pend::BlobStatus::kOk);
  runtime.set_params(params);
  const std::vector<uint8_t> vectors = read_vector_file("swing-up-" + name + ".pktv");
  uint32_t rows;
  std::memcpy(&rows, vectors.data() + 4, 4);
  size_t ticks = 0, same_mode = 0;
  double worst = 0.0;
  for (uint32_t k = 0; k < rows; ++k) {
    const size_t at = 12 + 20 * static_cast<size_t>(k);
    const float start = f32_at(vectors, at), pendulum = f32_at(vectors, at + 4), target = f32_at(vectors, at + 8);
    if (start > 0.5f) {
      runtime.reset(pendulum, target);
      continue;
    }
    const float output = runtime.tick(pendulum, target);
    const int mode = static_cast<int>(f32_at(vectors, at + 16));
    ++ticks;
    same_mode += static_cast<int>(runtime.mode()) == mode;
    if (static_cast<int>(runtime.mode()) == mode) worst = std::fmax(worst, std::fabs(output - f32_at(vectors, at + 12)));
  }
  MESSAGE(name << ": " << same_mode << " of " << ticks << " ticks in the same mode, largest target difference " << worst << " rad");
  CHECK(static_cast<double>(same_mode) >= 0.999 * static_cast<double>(ticks));
  CHECK(worst <= 2e-3);
}

}  // namespace

TEST_CASE("the device's swing-up follows the Python runtime: energy") { replay("energy"); }
TEST_CASE("the device's swing-up follows the Python runtime: minimum-time plan") { replay("trajopt"); }

TEST_CASE("uploads: the controller status after every chunk") {
  const std::vector<uint8_t> text = read_vector_file("uploads.json");
  const json vectors = json::parse(text.begin(), text.end());
  for (const json& scenario : vectors["scenarios"]) {
    CAPTURE(scenario["name"].get<std::string>());
    onboard = pend::Onboard();
    char buffer[512];
    const json& chunks = scenario["chunks"];
    for (size_t k = 0; k < chunks.size(); ++k) {
      CAPTURE(k);
      const std::vector<uint8_t> chunk = from_hex(chunks[k].get<std::string>());
      onboard.chunk(chunk.data(), chunk.size());
      REQUIRE(onboard.status_json(buffer, sizeof buffer) > 0);
      json status = json::parse(buffer);
      status.erase("last_refusal");  // the reason's words differ between the sides; the counts may not
      CHECK(status == scenario["status_after"][k]);
    }
  }
}

TEST_CASE("the device's policy makes the Python device's inputs and takes torch's actions") {
  const std::vector<uint8_t> blob = read_vector_file("r-dqn-realistic-policy.pkcb");
  onboard = pend::Onboard();
  upload(blob);
  REQUIRE(onboard.runs_policy());
  const std::vector<uint8_t> text = read_vector_file("policy-device.json");
  const json vectors = json::parse(text.begin(), text.end());
  size_t decisions = 0, same_action = 0;
  double worst_input = 0.0;
  for (const json& row : vectors["decisions"]) {
    if (row.contains("start")) {
      REQUIRE(onboard.start(0.0f, 0.0f));
      continue;
    }
    const json& r = row["reading"];
    const pend::Observation reading{r[0].get<uint32_t>(), r[1].get<int32_t>(), r[2].get<int32_t>(), r[3].get<double>(),
                                    r[4].get<double>(), r[5].get<double>(), 0};
    const uint32_t now = row["now_ms"].get<uint32_t>();
    float inputs[32];
    const size_t count = onboard.policy_inputs(reading, now, inputs, 32);
    REQUIRE(count == row["inputs"].size());
    for (size_t i = 0; i < count; ++i) {
      worst_input = std::fmax(worst_input, std::fabs(inputs[i] - row["inputs"][i].get<double>()));
    }
    int action = -1;
    for (int k = 0; k < 64 && !onboard.policy_tick(&reading, now, action); ++k) {
    }
    ++decisions;
    same_action += action == row["action"].get<int>();
  }
  MESSAGE("policy: " << same_action << " of " << decisions << " decisions the same, largest input difference "
                     << worst_input);
  CHECK(static_cast<double>(same_action) >= 0.999 * static_cast<double>(decisions));
  CHECK(worst_input <= 1e-5);
}

TEST_CASE("the device's observed policy makes the Python device's inputs and targets (layout 2)") {
  const std::vector<uint8_t> blob = read_vector_file("r-td3-bank-robust-policy.pkcb");
  onboard = pend::Onboard();
  upload(blob);
  REQUIRE(onboard.runs_policy());
  REQUIRE(onboard.observers().count() == 13);
  const std::vector<uint8_t> text = read_vector_file("observed-policy-device.json");
  const json vectors = json::parse(text.begin(), text.end());
  size_t decisions = 0, same_observer = 0;
  double worst_input = 0.0, worst_target = 0.0;
  for (const json& row : vectors["decisions"]) {
    if (row.contains("start")) {
      REQUIRE(onboard.start(0.0f, 0.0f));
      continue;
    }
    const json& r = row["reading"];
    const pend::Observation reading{r[0].get<uint32_t>(), r[1].get<int32_t>(), r[2].get<int32_t>(), r[3].get<double>(),
                                    r[4].get<double>(), r[5].get<double>(), 0};
    const uint32_t now = row["now_ms"].get<uint32_t>();
    pend::PolicyDecision decision;
    bool decided = false;
    for (int k = 0; k < 64 && !decided; ++k) decided = onboard.policy_tick(&reading, now, decision);
    REQUIRE(decided);
    REQUIRE(decision.continuous);
    size_t count = 0;
    const float* inputs = onboard.last_inputs(count);
    REQUIRE(count == row["inputs"].size());
    for (size_t i = 0; i < count; ++i) {
      const double want = row["inputs"][i].get<double>();
      worst_input = std::fmax(worst_input, std::fabs(inputs[i] - want) / std::fmax(1.0, std::fabs(want)));
    }
    worst_target = std::fmax(worst_target, std::fabs(decision.target_unit - row["target_unit"].get<double>()));
    onboard.follow(row["action"].get<float>(), row["target_unit"].get<double>());
    ++decisions;
    same_observer += onboard.observers().chosen() == row["observer"].get<int>();
  }
  MESSAGE("observed policy: " << decisions << " decisions, largest relative input difference " << worst_input
                              << ", largest target difference " << worst_target << ", the same observer shown in "
                              << same_observer);
  CHECK(decisions > 500);
  CHECK(same_observer == decisions);
  CHECK(worst_input <= 1e-5);
  CHECK(worst_target <= 1e-5);
}

TEST_CASE("a layout-2 policy with a damaged observer section is refused and changes nothing") {
  std::vector<uint8_t> blob = read_vector_file("r-td3-bank-robust-policy.pkcb");
  onboard = pend::Onboard();
  // the first candidate's arm inertia (just after the 12-byte envelope, the 16-byte policy header and the
  // 20-byte observer header) made negative, the CRC made good again: only the section's own check can refuse it
  blob[12 + 16 + 20 + 3] ^= 0x80;
  const uint32_t crc = pend::crc32(blob.data(), blob.size() - 4);
  for (int i = 0; i < 4; ++i) blob[blob.size() - 4 + i] = static_cast<uint8_t>(crc >> (8 * i));
  upload(blob);
  CHECK_FALSE(onboard.runs_policy());
  char buffer[512];
  REQUIRE(onboard.status_json(buffer, sizeof buffer) > 0);
  CHECK(json::parse(buffer)["refused"] == 1);
}
