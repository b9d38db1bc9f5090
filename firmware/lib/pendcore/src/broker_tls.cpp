#include "broker_tls.h"

#include <cstdio>
#include <cstring>

namespace pend {
namespace {

constexpr char kBegin[] = "-----BEGIN CERTIFICATE-----";
constexpr char kEnd[] = "-----END CERTIFICATE-----";
constexpr size_t kDiscardMinChars = 16;  // a base64 run this long is the rest of a refused paste, never a command

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

void trim(const char*& text, size_t& length) {
  while (length > 0 && is_space(*text)) { ++text; --length; }
  while (length > 0 && is_space(text[length - 1])) --length;
}

bool equals(const char* text, size_t length, const char* word) {
  return std::strlen(word) == length && std::memcmp(text, word, length) == 0;
}

bool starts_with(const char* text, size_t length, const char* prefix) {
  const size_t n = std::strlen(prefix);
  return length >= n && std::memcmp(text, prefix, n) == 0;
}

bool contains(const char* text, size_t length, const char* word) {
  const size_t n = std::strlen(word);
  for (size_t i = 0; i + n <= length; ++i) {
    if (std::memcmp(text + i, word, n) == 0) return true;
  }
  return false;
}

bool is_private_key(const char* text, size_t length) {
  return starts_with(text, length, "-----BEGIN ") && contains(text, length, "PRIVATE KEY");
}

int base64_value(char c) {
  if (c >= 'A' && c <= 'Z') return c - 'A';
  if (c >= 'a' && c <= 'z') return c - 'a' + 26;
  if (c >= '0' && c <= '9') return c - '0' + 52;
  if (c == '+') return 62;
  if (c == '/') return 63;
  return -1;
}

bool all_base64(const char* text, size_t length) {
  for (size_t i = 0; i < length; ++i) {
    if (base64_value(text[i]) < 0 && text[i] != '=') return false;
  }
  return true;
}

// The mbedTLS error codes a rig's handshake ends with (mbedtls/ssl.h, net_sockets.h, x509.h, bignum.h, ...).
constexpr int kX509VerifyFailed = -0x2700;
constexpr int kAllocFailed[] = {-0x7F00, -0x0010, -0x2880, -0x3F80, -0x006A, -0x4D80, -0x6180};
constexpr int kPeerClosed[] = {-0x7280, -0x0050, -0x7200, -0x004C, -0x004E, -0x7700};
constexpr int kFatalAlert = -0x7780;
constexpr int kSslTimeout = -0x6800;

bool one_of(int code, const int* codes, size_t count) {
  for (size_t i = 0; i < count; ++i) {
    if (codes[i] == code) return true;
  }
  return false;
}

}  // namespace

BrokerLink plan_broker_link(uint16_t configured_port, bool has_ca) {
  const uint16_t usual = has_ca ? kMqttTlsPort : kMqttPlainPort;
  return BrokerLink{has_ca, configured_port != 0 ? configured_port : usual};
}

const char* broker_port_hint(const BrokerLink& link) {
  if (link.tls && link.port == kMqttPlainPort) return "1883 is the plain MQTT port: `set port 0` uses 8883 with a CA";
  if (!link.tls && link.port == kMqttTlsPort) {
    return "8883 is the TLS port: give the rig the CA (`ca set`), or `set port 0` for 1883";
  }
  return nullptr;
}

bool parse_port(const char* text, size_t length, uint16_t& out) {
  if (length == 0 || length > 5) return false;
  uint32_t value = 0;
  for (size_t i = 0; i < length; ++i) {
    if (text[i] < '0' || text[i] > '9') return false;
    value = value * 10 + static_cast<uint32_t>(text[i] - '0');
  }
  if (value > 65535) return false;
  out = static_cast<uint16_t>(value);
  return true;
}

const char* ca_status_message(CaStatus status) {
  switch (status) {
    case CaStatus::kOk: return "ok";
    case CaStatus::kEmpty: return "no certificate between BEGIN and END: paste the whole of broker/ca.crt";
    case CaStatus::kNoBegin: return "expected -----BEGIN CERTIFICATE-----: paste the whole of broker/ca.crt";
    case CaStatus::kPrivateKey:
      return "that is a private key: never give a rig ca.key or server.key; paste broker/ca.crt";
    case CaStatus::kLineTooLong: return "a line is over 76 characters: paste broker/ca.crt as it is";
    case CaStatus::kBadCharacter:
      return "a line has a character base64 does not use (a command typed mid-paste ends it): paste broker/ca.crt "
             "again";
    case CaStatus::kUnevenLines:
      return "uneven lines: characters were lost on the way; paste again more slowly, or put the CA in config.h";
    case CaStatus::kBadPadding:
      return "the base64 ends wrongly: the paste was cut or joined; paste broker/ca.crt again";
    case CaStatus::kTooLong: return "over 3000 bytes: give one certificate (the classroom CA), not a chain";
    case CaStatus::kNotCertificate: return "this is not an X.509 certificate: paste broker/ca.crt";
    case CaStatus::kCut: return "the certificate is cut or has an extra line (its length disagrees): paste it again";
    case CaStatus::kNoEnd: return "no -----END CERTIFICATE----- line: paste the whole of broker/ca.crt";
    case CaStatus::kTrailingText: return "text after -----END CERTIFICATE-----: give one certificate only";
    case CaStatus::kUnknownCommand: return "ca commands: ca (show) | ca set (then paste broker/ca.crt) | ca clear";
  }
  return "unknown";
}

void PemBodyCheck::reset() { *this = PemBodyCheck(); }

void PemBodyCheck::emit(uint8_t byte) {
  if (der_bytes_ < sizeof head_) head_[der_bytes_] = byte;
  sha_.update(&byte, 1);
  ++der_bytes_;
}

CaStatus PemBodyCheck::line(const char* text, size_t length) {
  if (length > kMaxPemLineChars) return CaStatus::kLineTooLong;
  if (!all_base64(text, length)) return CaStatus::kBadCharacter;
  if (padding_ > 0) return CaStatus::kBadPadding;  // anything after the '=' that ends the data
  if (lines_ > 0 && (length > first_line_chars_ || short_line_seen_)) return CaStatus::kUnevenLines;
  if (lines_ == 0) first_line_chars_ = length;
  short_line_seen_ = short_line_seen_ || length < first_line_chars_;
  ++lines_;
  for (size_t i = 0; i < length; ++i) {
    ++chars_;
    if (text[i] == '=') {
      if (++padding_ > 2) return CaStatus::kBadPadding;
      continue;
    }
    if (padding_ > 0) return CaStatus::kBadPadding;
    bits_ = (bits_ << 6) | static_cast<uint32_t>(base64_value(text[i]));
    bit_count_ += 6;
    if (bit_count_ >= 8) {
      bit_count_ -= 8;
      emit(static_cast<uint8_t>(bits_ >> bit_count_));
      bits_ &= (1u << bit_count_) - 1;
    }
  }
  return CaStatus::kOk;
}

CaStatus PemBodyCheck::finish(CaInfo& info) {
  if (chars_ == 0) return CaStatus::kEmpty;
  if (chars_ % 4 != 0) return CaStatus::kBadPadding;
  // DER: a SEQUENCE with a definite length (short form, or 1-4 length bytes) holding a SEQUENCE (RFC 5280 4.1).
  if (der_bytes_ < 4 || head_[0] != 0x30) return CaStatus::kNotCertificate;
  size_t header = 2, content = head_[1];
  if (head_[1] & 0x80) {
    const size_t length_bytes = head_[1] & 0x7F;
    if (length_bytes == 0 || length_bytes > 4) return CaStatus::kNotCertificate;
    header = 2 + length_bytes;
    content = 0;
    for (size_t i = 0; i < length_bytes; ++i) content = content << 8 | head_[2 + i];
  }
  if (der_bytes_ <= header || head_[header] != 0x30) return CaStatus::kNotCertificate;
  if (header + content != der_bytes_) return CaStatus::kCut;
  info.der_bytes = der_bytes_;
  sha_.finish(info.sha256);
  return CaStatus::kOk;
}

CaStatus check_ca_pem(const char* pem, size_t length, CaInfo& info) {
  if (length > kMaxCaPemBytes) return CaStatus::kTooLong;
  enum class Where { kBefore, kInside, kAfter } where = Where::kBefore;
  PemBodyCheck body;
  size_t start = 0;
  while (start < length) {
    size_t end = start;
    while (end < length && pem[end] != '\n') ++end;
    const char* text = pem + start;
    size_t n = end - start;
    start = end + 1;
    trim(text, n);
    if (n == 0) continue;
    if (where == Where::kAfter) return CaStatus::kTrailingText;
    if (where == Where::kBefore) {
      if (is_private_key(text, n)) return CaStatus::kPrivateKey;
      if (!equals(text, n, kBegin)) return CaStatus::kNoBegin;
      where = Where::kInside;
    } else if (equals(text, n, kEnd)) {
      const CaStatus status = body.finish(info);
      if (status != CaStatus::kOk) return status;
      where = Where::kAfter;
    } else {
      if (starts_with(text, n, "-----")) return CaStatus::kNoEnd;
      const CaStatus status = body.line(text, n);
      if (status != CaStatus::kOk) return status;
    }
  }
  if (where == Where::kBefore) return CaStatus::kEmpty;
  return where == Where::kInside ? CaStatus::kNoEnd : CaStatus::kOk;
}

size_t format_fingerprint(const CaInfo& info, char* out, size_t capacity) {
  const size_t needed = 3 * Sha256::kDigestBytes;  // "AB:" x 32, the last ':' replaced by the terminator
  if (capacity < needed) return 0;
  static constexpr char kHex[] = "0123456789ABCDEF";
  for (size_t i = 0; i < Sha256::kDigestBytes; ++i) {
    out[3 * i] = kHex[info.sha256[i] >> 4];
    out[3 * i + 1] = kHex[info.sha256[i] & 0xF];
    out[3 * i + 2] = ':';
  }
  out[needed - 1] = '\0';
  return needed - 1;
}

CaCommand CaConsole::refuse(CaStatus status) {
  // Mid-paste, the rest of the paste is dropped quietly rather than read as commands.
  stage_ = stage_ == Stage::kIdle ? Stage::kIdle : Stage::kDiscard;
  length_ = 0;
  pem_[0] = '\0';
  error_ = status;
  return CaCommand::kRefused;
}

void CaConsole::begin_body() {
  length_ = 0;
  pem_[0] = '\0';
  body_.reset();
  append_line(kBegin, sizeof kBegin - 1);
  stage_ = Stage::kBody;
}

bool CaConsole::append_line(const char* text, size_t length) {
  if (length_ + length + 1 > kMaxCaPemBytes) return false;
  std::memcpy(pem_ + length_, text, length);
  length_ += length;
  pem_[length_++] = '\n';
  pem_[length_] = '\0';
  return true;
}

bool CaConsole::holds_link(uint32_t now_ms) const {
  return (stage_ == Stage::kAwaitBegin || stage_ == Stage::kBody) && now_ms - last_line_ms_ < kPasteQuietMs;
}

CaCommand CaConsole::feed(const char* line, size_t length, uint32_t now_ms) {
  trim(line, length);
  last_line_ms_ = now_ms;
  if (stage_ == Stage::kDiscard) {
    const bool rest_of_paste = !equals(line, length, kBegin) &&
        (starts_with(line, length, "-----") || (length >= kDiscardMinChars && all_base64(line, length)));
    if (rest_of_paste) {
      if (starts_with(line, length, "-----END ")) stage_ = Stage::kIdle;
      return CaCommand::kTaken;
    }
    stage_ = Stage::kIdle;  // anything else is the user typing again
  }
  if (stage_ == Stage::kIdle) {
    if (equals(line, length, "ca") || equals(line, length, "ca show")) return CaCommand::kShow;
    if (equals(line, length, "ca clear")) return CaCommand::kClear;
    if (equals(line, length, "ca set")) {
      length_ = 0;
      pem_[0] = '\0';
      stage_ = Stage::kAwaitBegin;
      return CaCommand::kStarted;
    }
    if (equals(line, length, kBegin)) {
      begin_body();
      return CaCommand::kStarted;
    }
    if (starts_with(line, length, "ca ")) return refuse(CaStatus::kUnknownCommand);
    if (is_private_key(line, length)) {
      stage_ = Stage::kBody;  // so that the key's own lines are dropped, not echoed back as unknown commands
      return refuse(CaStatus::kPrivateKey);
    }
    if (starts_with(line, length, "-----BEGIN ")) {
      stage_ = Stage::kBody;
      return refuse(CaStatus::kNoBegin);
    }
    return CaCommand::kNone;
  }
  if (length == 0) return CaCommand::kTaken;
  if (stage_ == Stage::kAwaitBegin) {
    if (equals(line, length, kBegin)) {
      begin_body();
      return CaCommand::kTaken;
    }
    return refuse(is_private_key(line, length) ? CaStatus::kPrivateKey : CaStatus::kNoBegin);
  }
  if (equals(line, length, kEnd)) {
    if (!append_line(line, length)) return refuse(CaStatus::kTooLong);
    const CaStatus status = body_.finish(info_);
    if (status != CaStatus::kOk) return refuse(status);
    stage_ = Stage::kIdle;
    error_ = CaStatus::kOk;
    return CaCommand::kAccepted;
  }
  if (starts_with(line, length, "-----")) return refuse(CaStatus::kNoEnd);
  const CaStatus status = body_.line(line, length);
  if (status != CaStatus::kOk) return refuse(status);
  if (!append_line(line, length)) return refuse(CaStatus::kTooLong);
  return CaCommand::kTaken;
}

size_t describe_link_failure(const char* host, const BrokerLink& link, const char* user, int mqtt_state,
                             int tls_error, const char* tls_text, uint32_t free_heap_bytes, char* out,
                             size_t capacity) {
  if (capacity == 0) return 0;
  const char* hint = broker_port_hint(link);
  const char* open = hint ? " (" : "";
  const char* close = hint ? ")" : "";
  hint = hint ? hint : "";
  const unsigned port = link.port;
  int n = 0;
  if (mqtt_state == 4 || mqtt_state == 5) {
    n = std::snprintf(out, capacity, "mqtt: the broker at %s:%u refused user '%s' (%s): set user and mqtt_password "
                      "from the instructor's credentials.csv", host, port, user,
                      mqtt_state == 4 ? "bad username or password" : "not authorised");
  } else if (mqtt_state >= 1 && mqtt_state <= 3) {
    n = std::snprintf(out, capacity, "mqtt: the broker at %s:%u refused the connection (MQTT code %d)", host, port,
                      mqtt_state);
  } else if (mqtt_state == -4) {
    n = std::snprintf(out, capacity, "mqtt: %s:%u took the connection but never answered the login: is it an MQTT "
                      "port?%s%s%s", host, port, open, hint, close);
  } else if (!link.tls) {
    n = std::snprintf(out, capacity, "mqtt: no connection to %s:%u: a wrong name or address, no broker running, or "
                      "a firewall%s%s%s", host, port, open, hint, close);
  } else if (tls_error == kX509VerifyFailed) {
    n = std::snprintf(out, capacity, "mqtt: the broker's certificate did not verify for '%s': set host to a name "
                      "the certificate lists (broker/server-names.txt), and check that `ca` shows the SHA-256 of the "
                      "broker's ca.crt", host);
  } else if (one_of(tls_error, kAllocFailed, sizeof kAllocFailed / sizeof kAllocFailed[0])) {
    n = std::snprintf(out, capacity, "mqtt: out of memory for the TLS handshake (%lu bytes of heap free, about "
                      "40 KB needed at peak): use the plain listener for this rig (`ca clear`, `save`)",
                      static_cast<unsigned long>(free_heap_bytes));
  } else if (one_of(tls_error, kPeerClosed, sizeof kPeerClosed / sizeof kPeerClosed[0])) {
    n = std::snprintf(out, capacity, "mqtt: %s:%u closed the TLS handshake: is it the broker's TLS port? (8883; 1883 "
                      "is plain MQTT)", host, port);
  } else if (tls_error == kFatalAlert) {
    n = std::snprintf(out, capacity, "mqtt: the broker at %s:%u ended the TLS handshake with an alert: its log says "
                      "why", host, port);
  } else if (tls_error == 0 || tls_error == -1 || tls_error == kSslTimeout) {
    n = std::snprintf(out, capacity, "mqtt: no TLS connection to %s:%u: a wrong name or address, no broker running, a "
                      "firewall, or no handshake within %lu s%s%s%s", host, port,
                      static_cast<unsigned long>(kTlsHandshakeTimeoutS), open, hint, close);
  } else if (tls_error <= -0x1000 && tls_error > -0x3000) {
    n = std::snprintf(out, capacity, "mqtt: a certificate could not be read: the rig's CA (`ca set` it again) or the "
                      "broker's (an algorithm Mbed TLS lacks?)");
  } else {
    n = std::snprintf(out, capacity, "mqtt: TLS to %s:%u failed", host, port);
  }
  if (n > 0 && tls_error != 0 && tls_error != -1 && static_cast<size_t>(n) < capacity) {
    const int extra = std::snprintf(out + n, capacity - static_cast<size_t>(n), " [mbedTLS -0x%04X%s%s]",
                                    static_cast<unsigned>(-tls_error), tls_text && *tls_text ? ": " : "",
                                    tls_text ? tls_text : "");
    if (extra > 0) n += extra;
  }
  const size_t written = n < 0 ? 0 : (static_cast<size_t>(n) < capacity ? static_cast<size_t>(n) : capacity - 1);
  for (size_t i = 0; i < written; ++i) {
    if (out[i] == '\n' || out[i] == '\r') out[i] = ' ';  // one line, whatever the library's text holds
  }
  out[written] = '\0';
  return written;
}

}  // namespace pend
