// SHA-256 (FIPS 180-4), streamed: the serial console prints a stored CA's fingerprint with it, the same
// value `openssl x509 -in broker/ca.crt -noout -fingerprint -sha256` prints, so an instructor can tell the
// right CA is on a rig. Portable and allocation-free like the rest of the core.
#pragma once

#include <cstddef>
#include <cstdint>

namespace pend {

class Sha256 {
 public:
  static constexpr size_t kDigestBytes = 32;

  Sha256();
  void update(const uint8_t* data, size_t length);
  // Pads, writes the digest and leaves the object to be reset before reuse.
  void finish(uint8_t digest[kDigestBytes]);
  void reset();

 private:
  void compress(const uint8_t block[64]);

  uint32_t state_[8];
  uint8_t block_[64];
  size_t block_bytes_ = 0;
  uint64_t total_bytes_ = 0;
};

}  // namespace pend
