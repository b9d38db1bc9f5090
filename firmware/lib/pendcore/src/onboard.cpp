#include "onboard.h"

#include <cstdio>
#include <cstring>

namespace pend {

namespace {

uint32_t read_u32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 | static_cast<uint32_t>(p[2]) << 16 |
         static_cast<uint32_t>(p[3]) << 24;
}

}  // namespace

bool is_chunk(const uint8_t* payload, size_t length) {
  return length >= 4 && std::memcmp(payload, "PKUP", 4) == 0;
}

void Onboard::refuse(const char* reason) {
  ++refused_;
  last_refusal_ = reason;
  received_ = total_ = 0;
}

bool Onboard::chunk(const uint8_t* payload, size_t length) {
  if (length < kChunkHeaderBytes || !is_chunk(payload, length)) {
    ++ignored_;
    return false;
  }
  const uint32_t offset = read_u32(payload + 4), total = read_u32(payload + 8);
  const size_t bytes = length - kChunkHeaderBytes;
  if (bytes == 0 || bytes > kMaxChunkBytes) {
    ++ignored_;
    return false;
  }
  if (offset == 0) {
    if (total > kMaxBlobBytes) {
      refuse(blob_status_name(BlobStatus::kTooLarge));
      return true;
    }
    received_ = 0;
    total_ = total;
  } else if (total != total_ || offset != received_ || total_ == 0) {
    ++ignored_;  // a chunk after a lost one, or of another upload: the host resumes
    return false;
  }
  if (offset + bytes > total_) {
    refuse("a chunk runs past the blob's size");
    return true;
  }
  std::memcpy(buffer_ + received_, payload + kChunkHeaderBytes, bytes);
  received_ += bytes;
  if (received_ < total_) return false;
  install();
  return true;
}

void Onboard::install() {
  uint16_t kind = 0;
  const uint8_t* payload = nullptr;
  size_t payload_length = 0;
  BlobStatus status = open_blob(buffer_, total_, kind, payload, payload_length);
  if (status == BlobStatus::kOk) {
    status = kind == static_cast<uint16_t>(ControllerKind::kSwingUp) ? parse_swing_up(payload, payload_length, params_)
                                                                     : BlobStatus::kUnknownKind;
  }
  if (status != BlobStatus::kOk) {
    refuse(kind != static_cast<uint16_t>(ControllerKind::kSwingUp) && status == BlobStatus::kUnknownKind
               ? "this device runs swing-up controllers"
               : blob_status_name(status));
    return;
  }
  runtime_.set_params(params_);
  has_controller_ = true;
  running_ = false;
  active_bytes_ = static_cast<uint32_t>(total_);
  active_crc_ = crc32(buffer_, total_);
  ++accepted_;
  received_ = total_ = 0;
}

bool Onboard::start(float pendulum_rad, float target_rad) {
  if (!has_controller_) return false;
  runtime_.reset(pendulum_rad, target_rad);
  running_ = true;
  return true;
}

size_t Onboard::status_json(char* buffer, size_t capacity) const {
  const int length = std::snprintf(
      buffer, capacity,
      "{\"kind\":%s,\"bytes\":%lu,\"crc\":%lu,\"running\":%s,\"received\":%lu,\"total\":%lu,\"accepted\":%lu,"
      "\"refused\":%lu,\"ignored_chunks\":%lu,\"last_refusal\":\"%s\"}",
      has_controller_ ? "\"swing-up\"" : "null", static_cast<unsigned long>(active_bytes_),
      static_cast<unsigned long>(active_crc_), running_ ? "true" : "false", static_cast<unsigned long>(received_),
      static_cast<unsigned long>(total_), static_cast<unsigned long>(accepted_), static_cast<unsigned long>(refused_),
      static_cast<unsigned long>(ignored_), last_refusal_);
  return (length < 0 || static_cast<size_t>(length) >= capacity) ? 0 : static_cast<size_t>(length);
}

}  // namespace pend
