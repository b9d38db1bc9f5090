// The rig's link to the broker over TLS, as far as it is logic: the classroom CA pasted on the serial console
// (PEM, line by line) and checked before it replaces anything, the transport and port that follow from it,
// and a failed connection's likely cause in one line. main.cpp keeps the CA in flash (Preferences) and gives
// it to WiFiClientSecure; everything here is host-tested (test/test_broker_tls.cpp).
#pragma once

#include <cstddef>
#include <cstdint>

#include "sha256.h"

namespace pend {

constexpr uint16_t kMqttPlainPort = 1883;
constexpr uint16_t kMqttTlsPort = 8883;
// A classroom CA (`pendkit broker-config --tls`, RSA-2048) is about 1.2 KB of PEM, an RSA-4096 one about 2 KB;
// the limit stays under NVS's 4000 bytes for a string (ESP-IDF's nvs_flash documentation).
constexpr size_t kMaxCaPemBytes = 3000;
constexpr size_t kMaxPemLineChars = 76;  // RFC 7468 writes 64; some tools write 76
// How long one TLS handshake may block the loop, and how often a lost link is tried again.
constexpr uint32_t kTlsHandshakeTimeoutS = 10;
constexpr uint32_t kReconnectPeriodMs = 2000;
// While a CA is being pasted the rig makes no connection attempt (a handshake blocks the loop, and the serial
// buffer overflows meanwhile), unless the paste has been quiet this long.
constexpr uint32_t kPasteQuietMs = 10000;

// What the rig connects with: TLS exactly when it has a CA; port 0 means the transport's usual port.
struct BrokerLink {
  bool tls;
  uint16_t port;
};
BrokerLink plan_broker_link(uint16_t configured_port, bool has_ca);
// One line when the port is the other transport's usual one (TLS to 1883, plain MQTT to 8883), else nullptr.
const char* broker_port_hint(const BrokerLink& link);
// `set port` values: 0 (the usual port) to 65535, decimal digits only. On failure `out` is untouched.
bool parse_port(const char* text, size_t length, uint16_t& out);

enum class CaStatus : uint8_t {
  kOk,
  kEmpty,           // nothing between BEGIN and END
  kNoBegin,         // something else where -----BEGIN CERTIFICATE----- belongs
  kPrivateKey,      // a private key was pasted
  kLineTooLong,     // a line over kMaxPemLineChars
  kBadCharacter,    // a character base64 does not use
  kUnevenLines,     // a line longer than the first, or one after a short line: characters lost on the way
  kBadPadding,      // '=' in the middle, or a length that is not a multiple of 4
  kTooLong,         // more than kMaxCaPemBytes of PEM
  kNotCertificate,  // the bytes are not a DER SEQUENCE holding a SEQUENCE
  kCut,             // the DER length disagrees with what arrived: a lost or an extra line
  kNoEnd,           // no -----END CERTIFICATE-----
  kTrailingText,    // more after END: one certificate only
  kUnknownCommand,  // `ca <something else>`
};

// What went wrong and what to do, one line.
const char* ca_status_message(CaStatus status);

struct CaInfo {
  size_t der_bytes = 0;
  uint8_t sha256[Sha256::kDigestBytes] = {};
};

// Checks a whole PEM (config.h's, or the one stored in flash): one certificate from BEGIN to END.
CaStatus check_ca_pem(const char* pem, size_t length, CaInfo& info);
// "AB:CD:..." as `openssl x509 -noout -fingerprint -sha256` prints it (95 characters); 0 if it does not fit.
size_t format_fingerprint(const CaInfo& info, char* out, size_t capacity);

// The base64 lines between BEGIN and END, checked as they arrive (the alphabet, even lines, padding) and,
// at the end, the DER length against the bytes that came. Shared by check_ca_pem and CaConsole.
class PemBodyCheck {
 public:
  void reset();
  CaStatus line(const char* text, size_t length);
  CaStatus finish(CaInfo& info);

 private:
  void emit(uint8_t byte);

  Sha256 sha_;
  uint32_t bits_ = 0;
  int bit_count_ = 0;
  size_t chars_ = 0, padding_ = 0, der_bytes_ = 0, first_line_chars_ = 0, lines_ = 0;
  bool short_line_seen_ = false;
  uint8_t head_[8] = {};
};

enum class CaCommand : uint8_t {
  kNone,      // not for the CA: the caller handles the line
  kShow,      // `ca` or `ca show`
  kClear,     // `ca clear`
  kStarted,   // `ca set`, or a BEGIN line: a paste has begun
  kTaken,     // one more line of the paste
  kAccepted,  // END, and the whole certificate checked: pem() and info() hold it
  kRefused,   // the paste or the command is wrong (error() says why); the paste is dropped
};

// The serial console's `ca` commands and the paste that follows `ca set` (or starts with a BEGIN line). It never
// touches the stored CA: the caller stores pem() on kAccepted and clears its own on kClear. After a refusal
// the rest of that paste is dropped quietly (kTaken) instead of being read as commands.
class CaConsole {
 public:
  CaCommand feed(const char* line, size_t length, uint32_t now_ms);
  // True while a paste is under way and its last line came less than kPasteQuietMs ago.
  bool holds_link(uint32_t now_ms) const;
  const char* pem() const { return pem_; }
  size_t pem_length() const { return length_; }
  const CaInfo& info() const { return info_; }
  CaStatus error() const { return error_; }

 private:
  enum class Stage : uint8_t { kIdle, kAwaitBegin, kBody, kDiscard };
  CaCommand refuse(CaStatus status);
  void begin_body();
  bool append_line(const char* text, size_t length);

  char pem_[kMaxCaPemBytes + 1] = {};
  size_t length_ = 0;
  Stage stage_ = Stage::kIdle;
  uint32_t last_line_ms_ = 0;
  CaStatus error_ = CaStatus::kOk;
  CaInfo info_;
  PemBodyCheck body_;
};

// Why a connection attempt failed, in one line for the serial console. `mqtt_state` is PubSubClient's state()
// after connect() failed; `tls_error` WiFiClientSecure::lastError()'s code (0: none, or a plain link) and
// `tls_text` its text (may be empty). Returns the line's length (cut to fit `capacity`).
size_t describe_link_failure(const char* host, const BrokerLink& link, const char* user, int mqtt_state,
                             int tls_error, const char* tls_text, uint32_t free_heap_bytes, char* out,
                             size_t capacity);

}  // namespace pend
