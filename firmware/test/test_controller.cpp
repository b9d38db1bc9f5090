// The device's controller runtime against the shared vectors: the shipped R-DQN's blob, 10 000 recorded
// inputs and torch's Q-values for them (tests/vectors/r-dqn-realistic.*, written by pendkit.device.export).
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "controller.h"
#include "vector_files.h"

namespace {

pend::Controller controller;  // 71 KB: static, as on the device

}  // namespace

TEST_CASE("the device runtime gives torch's outputs on the recorded inputs") {
  const std::vector<uint8_t> blob = read_vector_file("r-dqn-realistic.pkcb");
  REQUIRE(controller.load(blob.data(), blob.size()) == pend::BlobStatus::kOk);
  const std::vector<uint8_t> vectors = read_vector_file("r-dqn-realistic.pktv");
  REQUIRE(std::memcmp(vectors.data(), "PKTV", 4) == 0);
  uint32_t steps;
  uint16_t n_in, n_out;
  std::memcpy(&steps, vectors.data() + 4, 4);
  std::memcpy(&n_in, vectors.data() + 8, 2);
  std::memcpy(&n_out, vectors.data() + 10, 2);
  REQUIRE(n_in == controller.input_size());
  REQUIRE(n_out == controller.output_size());
  const size_t row = 4u * (1 + n_in + n_out);
  float inputs[64], outputs[16];
  size_t same = 0;
  double worst = 0.0;
  for (uint32_t k = 0; k < steps; ++k) {
    const size_t at = 12 + k * row;
    if (f32_at(vectors, at) > 0.5f) controller.reset();
    for (size_t i = 0; i < n_in; ++i) inputs[i] = f32_at(vectors, at + 4 * (1 + i));
    const pend::StepResult result = controller.step(inputs, n_in, outputs, 16);
    REQUIRE(result.ok);
    size_t best = 0;
    for (size_t i = 0; i < n_out; ++i) {
      const float expected = f32_at(vectors, at + 4 * (1 + n_in + i));
      worst = std::fmax(worst, std::fabs(outputs[i] - expected) / std::fmax(1.0, std::fabs(expected)));
      best = expected > f32_at(vectors, at + 4 * (1 + n_in + best)) ? i : best;
    }
    same += static_cast<size_t>(result.action) == best;
  }
  CHECK(worst <= 1e-5);  // relative: Q-values reach 150, where float32's spacing is 1.5e-5
  CHECK(static_cast<double>(same) / steps >= 0.999);
  MESSAGE("max relative error " << worst << ", same action on " << same << " of " << steps
          << ", " << controller.multiply_accumulates() << " multiply-accumulates per step");
}

TEST_CASE("a damaged, cut or oversized blob is refused and the active controller stays") {
  std::vector<uint8_t> blob = read_vector_file("r-dqn-realistic.pkcb");
  REQUIRE(controller.load(blob.data(), blob.size()) == pend::BlobStatus::kOk);
  const size_t weights = controller.weight_count();
  CHECK(controller.load(blob.data(), blob.size() - 1) == pend::BlobStatus::kBadLength);
  CHECK(controller.load(blob.data(), 10) == pend::BlobStatus::kTooShort);
  CHECK(controller.load(blob.data(), pend::kMaxBlobBytes + 1) == pend::BlobStatus::kTooLarge);
  std::vector<uint8_t> flipped = blob;
  flipped[100] ^= 0x04;
  CHECK(controller.load(flipped.data(), flipped.size()) == pend::BlobStatus::kBadCrc);
  std::vector<uint8_t> magic = blob;
  magic[0] = 'X';
  CHECK(controller.load(magic.data(), magic.size()) == pend::BlobStatus::kBadMagic);
  CHECK(controller.kind() == pend::ControllerKind::kNetwork);
  CHECK(controller.weight_count() == weights);
  float inputs[64] = {};
  CHECK(controller.step(inputs, controller.input_size()).ok);
  CHECK_FALSE(controller.step(inputs, controller.input_size() + 1).ok);  // wrong input size: refused
}

TEST_CASE("crc32 is zlib's") {
  const uint8_t text[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
  CHECK(pend::crc32(text, 9) == 0xCBF43926u);
}
