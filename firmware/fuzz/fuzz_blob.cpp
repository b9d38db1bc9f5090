// libFuzzer target: arbitrary bytes as a controller blob (and, when they load, one step on inputs taken from
// the same bytes), and the same bytes uploaded in chunks to the device's onboard controller (a swing-up
// or a policy that loads runs a few ticks). Any crash or sanitizer report is a bug; so is a refused blob that changed
// the active one.
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "controller.h"
#include "onboard.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static pend::Controller controller;
  const pend::ControllerKind before = controller.kind();
  const size_t weights = controller.weight_count();
  pend::BlobStatus status = controller.load(data, size);
  if (status != pend::BlobStatus::kOk && (controller.kind() != before || controller.weight_count() != weights)) {
    __builtin_trap();
  }
  // The same bytes with a length and a CRC that agree, so that mutations reach the shape checks.
  static uint8_t sealed[pend::kMaxBlobBytes];
  if (size >= 16 && size <= sizeof sealed) {
    std::memcpy(sealed, data, size);
    const uint32_t payload = static_cast<uint32_t>(size - 16);
    for (int i = 0; i < 4; ++i) sealed[8 + i] = static_cast<uint8_t>(payload >> (8 * i));
    const uint32_t crc = pend::crc32(sealed, size - 4);
    for (int i = 0; i < 4; ++i) sealed[size - 4 + i] = static_cast<uint8_t>(crc >> (8 * i));
    const pend::ControllerKind kind = controller.kind();
    const size_t held = controller.weight_count();
    status = controller.load(sealed, size);
    if (status != pend::BlobStatus::kOk && (controller.kind() != kind || controller.weight_count() != held)) {
      __builtin_trap();
    }
  }
  static pend::Onboard onboard;
  if (size >= 16 && size <= sizeof sealed) {
    uint8_t chunk[pend::kChunkHeaderBytes + pend::kMaxChunkBytes];
    for (size_t offset = 0; offset < size; offset += pend::kMaxChunkBytes) {
      const size_t bytes = size - offset < pend::kMaxChunkBytes ? size - offset : pend::kMaxChunkBytes;
      std::memcpy(chunk, "PKUP", 4);
      for (int i = 0; i < 4; ++i) chunk[4 + i] = static_cast<uint8_t>(offset >> (8 * i));
      for (int i = 0; i < 4; ++i) chunk[8 + i] = static_cast<uint8_t>(size >> (8 * i));
      std::memcpy(chunk + pend::kChunkHeaderBytes, sealed + offset, bytes);
      onboard.chunk(chunk, pend::kChunkHeaderBytes + bytes);
    }
    if (onboard.start(static_cast<float>(data[0]) / 40.0f, 0.0f)) {
      if (onboard.runs_policy()) {  // readings made of the same bytes: the observers and network on them
        pend::PolicyDecision decision;
        for (uint32_t k = 0; k < 24; ++k) {
          const pend::Observation reading{k * 10, data[k % size] * 4, 150 + data[(k + 1) % size],
                                          data[(k + 2) % size] / 16.0 - 8.0, data[(k + 3) % size] - 128.0,
                                          data[(k + 4) % size] * 2.0 - 256.0, 0};
          onboard.policy_tick(&reading, k * 10 + data[(k + 5) % size] % 30, decision);
        }
      } else {
        for (int k = 0; k < 12; ++k) onboard.tick(static_cast<float>(data[k % size]) / 40.0f, 0.0f);
      }
      onboard.stop();
    }
  }
  onboard.chunk(data, size);  // the raw bytes as one chunk: garbage, or a chunk of some upload
  float inputs[512] = {};
  const size_t count = controller.input_size();
  for (size_t i = 0; i < count && i < 512 && size > 0; ++i) inputs[i] = static_cast<float>(data[i % size] % 13) - 6.0f;
  float outputs[512];
  controller.step(inputs, count, outputs, 512);
  return 0;
}
