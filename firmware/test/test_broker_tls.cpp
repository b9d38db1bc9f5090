// The rig's TLS logic: SHA-256 against FIPS 180-4's examples, CA certificates checked and fingerprinted as
// openssl does, the serial console's paste (lost characters, typed commands, private keys, chains), the
// port that follows from a CA, and the one-line causes of a failed connection.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "broker_tls.h"
#include "sha256.h"

namespace {

// Throwaway CAs made for these tests with openssl (their keys were discarded). The fingerprints are what
// `openssl x509 -noout -fingerprint -sha256` printed for them.
const char kRsaCa[] =
    "-----BEGIN CERTIFICATE-----\n"
    "MIIDFTCCAf2gAwIBAgIUAtBL6pTLBjQ81OkmZrRm964CPDkwDQYJKoZIhvcNAQEL\n"
    "BQAwGjEYMBYGA1UEAwwPcGVuZGtpdCB0ZXN0IENBMB4XDTI2MTEyODIwNDg0MFoX\n"
    "DTM2MTEyNTIwNDg0MFowGjEYMBYGA1UEAwwPcGVuZGtpdCB0ZXN0IENBMIIBIjAN\n"
    "BgkqhkiG9w0BAQEFAAOCAQ8AMIIBCgKCAQEA+G5SB6i6cQ341rqywhkErIjkd61x\n"
    "pXrpelGMjEfVOcfTknD+FxB9SEA8Fr92AmrLM8Ziod/nXivagKZeKjy9Z5zQPiK8\n"
    "EgJ9tiN4vJWET01ZhrkZRYI44iNUJbLmbKNwmmADOi/8BKGw5ZJI/5Suarfd0ijQ\n"
    "hLXAjYuLbeYygN8cqgPgsjaRJHlCbGAwiOc6WH/Z40MtHvsNErtGzONiZz6GIsCc\n"
    "z192qlZbveO9ldL31v2opA05wYuUCDUbT4boMigZK0ryjulyBvBDl1jR136h4AMW\n"
    "Vz/4yzJk3hm1rd82IhpjcVoApXFVdZuwWzL6WD+0gUn3M18e0slrQiFxRwIDAQAB\n"
    "o1MwUTAdBgNVHQ4EFgQUHAOLO3Mp/qdqaEfWDarH+5sedsQwHwYDVR0jBBgwFoAU\n"
    "HAOLO3Mp/qdqaEfWDarH+5sedsQwDwYDVR0TAQH/BAUwAwEB/zANBgkqhkiG9w0B\n"
    "AQsFAAOCAQEAnptGjVSJezQMVuzRueoghj811XiwiHxsXLJzDnXyArKMbUkqK1k2\n"
    "lmhU4Ydo89TOONMIhWsAiq20NDBtOn2LqTIYUQ5Irw8Ew3loPaKd0F3maoZQFhnO\n"
    "cvTlQueORarkMX+fbKgCfAOzjCas0HIexxtBwiN//QOPPfwFbTTlJc6YmIBRXA12\n"
    "+dry57GRnGb/5Jalw2RdYZDYbTV0d4he9ydDKuzCPUzwdNrQVgsh0OTY3jLS7tNu\n"
    "6k4TyFspEPjS22CSsLX7ffRpAMHNjsWBsScnF3k1pNuo8WJCBNajl0rOtfZdJAeU\n"
    "9IQx++mMvYfySOUbAC7fGP9vkUPuFL+Ngw==\n"
    "-----END CERTIFICATE-----\n";
const char kRsaFingerprint[] =
    "A7:68:F1:9E:F1:B8:48:71:1C:98:97:73:14:23:C6:10:A7:DE:B6:BB:E9:0A:A1:1C:6A:18:DC:DA:FE:21:DB:68";

const char kEcCa[] =
    "-----BEGIN CERTIFICATE-----\n"
    "MIIBkDCCATWgAwIBAgIUWIlMqKmHkuYUd8Hk6IWoi6XKmKkwCgYIKoZIzj0EAwIw\n"
    "HTEbMBkGA1UEAwwScGVuZGtpdCB0ZXN0IEVDIENBMB4XDTI2MTEyODIwNDg0MFoX\n"
    "DTM2MTEyNTIwNDg0MFowHTEbMBkGA1UEAwwScGVuZGtpdCB0ZXN0IEVDIENBMFkw\n"
    "EwYHKoZIzj0CAQYIKoZIzj0DAQcDQgAEAQ8T/WiGqVBLSCtRsYdKqDXDDPjUzCND\n"
    "INJ327pBwsYxx/IaZVA54nkXVsgA+ToEr2dbxh4ha1iY17l6/oVt3qNTMFEwHQYD\n"
    "VR0OBBYEFKgeU7ueDTRwCg57Fn2FbaEkRtBYMB8GA1UdIwQYMBaAFKgeU7ueDTRw\n"
    "Cg57Fn2FbaEkRtBYMA8GA1UdEwEB/wQFMAMBAf8wCgYIKoZIzj0EAwIDSQAwRgIh\n"
    "AL213nl7PR035ruxKWmkA2luehB0V7Z0AMPpCrKaY1RXAiEA1B079ptRH2zFpqlA\n"
    "z0jRRp+4z8vjNwwLwE+dTEFecxY=\n"
    "-----END CERTIFICATE-----\n";
const char kEcFingerprint[] =
    "1F:53:58:99:C4:F5:90:9D:D7:CD:E7:FC:CA:33:92:50:65:25:43:6A:CA:30:1A:92:89:C1:C0:07:96:BC:BB:82";

using Lines = std::vector<std::string>;

Lines split(const std::string& text) {
  Lines lines;
  size_t start = 0;
  for (size_t end; (end = text.find('\n', start)) != std::string::npos; start = end + 1) {
    lines.push_back(text.substr(start, end - start));
  }
  return lines;
}

std::string join(const Lines& lines, const char* newline = "\n") {
  std::string text;
  for (const std::string& line : lines) text += line + newline;
  return text;
}

std::string hex(const uint8_t* bytes, size_t count) {
  static const char digits[] = "0123456789abcdef";
  std::string out;
  for (size_t i = 0; i < count; ++i) out += {digits[bytes[i] >> 4], digits[bytes[i] & 0xF]};
  return out;
}

pend::CaStatus check(const std::string& pem, pend::CaInfo* info_out = nullptr) {
  pend::CaInfo info;
  const pend::CaStatus status = pend::check_ca_pem(pem.data(), pem.size(), info);
  if (info_out) *info_out = info;
  return status;
}

std::string fingerprint(const pend::CaInfo& info) {
  char text[96];
  REQUIRE(pend::format_fingerprint(info, text, sizeof text) == 95);
  return text;
}

// Feeds lines as the console receives them; returns what each line did.
std::vector<pend::CaCommand> feed(pend::CaConsole& console, const Lines& lines, uint32_t now_ms = 0) {
  std::vector<pend::CaCommand> results;
  for (const std::string& line : lines) results.push_back(console.feed(line.data(), line.size(), now_ms));
  return results;
}

}  // namespace

TEST_CASE("sha256: FIPS 180-4's examples, fed whole and in pieces that straddle the 64-byte blocks") {
  struct Row { std::string message; const char* digest; };
  const Row rows[] = {
      {"", "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"},
      {"abc", "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"},
      {"abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq",
       "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1"},
      {std::string(1000000, 'a'), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0"},
  };
  for (const Row& row : rows) {
    CAPTURE(row.message.size());
    for (size_t piece : {row.message.size() + 1, size_t{1}, size_t{63}, size_t{65}}) {
      pend::Sha256 sha;
      for (size_t at = 0; at < row.message.size(); at += piece) {
        const size_t n = std::min(piece, row.message.size() - at);
        sha.update(reinterpret_cast<const uint8_t*>(row.message.data()) + at, n);
      }
      uint8_t digest[pend::Sha256::kDigestBytes];
      sha.finish(digest);
      CHECK(hex(digest, sizeof digest) == row.digest);
    }
  }
}

TEST_CASE("ca: an RSA and an EC CA pass, with openssl's fingerprints, whatever the line endings") {
  pend::CaInfo info;
  CHECK(check(kRsaCa, &info) == pend::CaStatus::kOk);
  CHECK(info.der_bytes == 793);
  CHECK(fingerprint(info) == kRsaFingerprint);
  CHECK(check(kEcCa, &info) == pend::CaStatus::kOk);
  CHECK(info.der_bytes == 404);
  CHECK(fingerprint(info) == kEcFingerprint);
  CHECK(check("\r\n  \n" + join(split(kRsaCa), "\r\n") + "\n\n", &info) == pend::CaStatus::kOk);
  CHECK(fingerprint(info) == kRsaFingerprint);
  const std::string no_final_newline = std::string(kEcCa, sizeof kEcCa - 2);
  CHECK(check(no_final_newline, &info) == pend::CaStatus::kOk);
  char small[95];
  CHECK(pend::format_fingerprint(info, small, sizeof small) == 0);
}

TEST_CASE("ca: each damage has its own one-line cause") {
  using Change = std::function<void(Lines&)>;
  struct Row { const char* what; Change change; pend::CaStatus status; };
  const Row rows[] = {
      {"nothing at all", [](Lines& l) { l.clear(); }, pend::CaStatus::kEmpty},
      {"no BEGIN line", [](Lines& l) { l.erase(l.begin()); }, pend::CaStatus::kNoBegin},
      {"a private key", [](Lines& l) { l.front() = "-----BEGIN PRIVATE KEY-----"; }, pend::CaStatus::kPrivateKey},
      {"an RSA private key", [](Lines& l) { l.front() = "-----BEGIN RSA PRIVATE KEY-----"; },
       pend::CaStatus::kPrivateKey},
      {"no END line", [](Lines& l) { l.pop_back(); }, pend::CaStatus::kNoEnd},
      {"another marker inside", [](Lines& l) { l[5] = "-----END CERT-----"; }, pend::CaStatus::kNoEnd},
      {"a whole line lost", [](Lines& l) { l.erase(l.begin() + 4); }, pend::CaStatus::kCut},
      {"a line twice", [](Lines& l) { l.insert(l.begin() + 4, l[4]); }, pend::CaStatus::kCut},
      {"a character lost mid-way", [](Lines& l) { l[3].erase(10, 1); }, pend::CaStatus::kUnevenLines},
      {"a character added mid-way", [](Lines& l) { l[3].insert(10, "A"); }, pend::CaStatus::kUnevenLines},
      {"a character lost at the end", [](Lines& l) { l[l.size() - 2].erase(3, 1); }, pend::CaStatus::kBadPadding},
      {"'=' inside", [](Lines& l) { l[6][20] = '='; }, pend::CaStatus::kBadPadding},
      {"a typed word", [](Lines& l) { l[6] = "set host pi.local"; }, pend::CaStatus::kBadCharacter},
      {"two lines joined", [](Lines& l) { l[2] += l[3]; l.erase(l.begin() + 3); }, pend::CaStatus::kLineTooLong},
      {"not DER", [](Lines& l) { l[1][0] = 'A'; }, pend::CaStatus::kNotCertificate},
      {"no BEGIN to END body", [](Lines& l) { l.erase(l.begin() + 1, l.end() - 1); }, pend::CaStatus::kEmpty},
      {"a chain of two", [](Lines& l) { const Lines copy = l; l.insert(l.end(), copy.begin(), copy.end()); },
       pend::CaStatus::kTrailingText},
      {"over 3000 bytes", [](Lines& l) { l.insert(l.begin() + 2, 45, std::string(64, 'A')); },
       pend::CaStatus::kTooLong},
  };
  for (const Row& row : rows) {
    CAPTURE(row.what);
    Lines lines = split(kRsaCa);
    row.change(lines);
    const pend::CaStatus status = check(join(lines));
    CHECK(pend::ca_status_message(status) == std::string(pend::ca_status_message(row.status)));
    CHECK(std::strchr(pend::ca_status_message(status), '\n') == nullptr);
  }
}

TEST_CASE("console: `ca set` then the paste stores a checked certificate, the same one check_ca_pem reads") {
  pend::CaConsole console;
  Lines lines = {"ca set", ""};
  for (const std::string& line : split(kRsaCa)) lines.push_back("  " + line + "\r");
  const std::vector<pend::CaCommand> results = feed(console, lines, 1000);
  CHECK(results.front() == pend::CaCommand::kStarted);
  for (size_t i = 1; i + 1 < results.size(); ++i) CHECK(results[i] == pend::CaCommand::kTaken);
  CHECK(results.back() == pend::CaCommand::kAccepted);
  CHECK(std::string(console.pem()) == kRsaCa);  // normalised: trimmed lines, '\n' endings
  CHECK(console.pem_length() == std::strlen(kRsaCa));
  CHECK(fingerprint(console.info()) == kRsaFingerprint);
  CHECK_FALSE(console.holds_link(1001));
  pend::CaInfo stored;
  CHECK(pend::check_ca_pem(console.pem(), console.pem_length(), stored) == pend::CaStatus::kOk);
  CHECK(fingerprint(stored) == kRsaFingerprint);
}

TEST_CASE("console: a BEGIN line alone starts a paste; `ca` commands; other lines are the caller's") {
  pend::CaConsole console;
  const std::vector<pend::CaCommand> results = feed(console, split(kEcCa));
  CHECK(results.front() == pend::CaCommand::kStarted);
  CHECK(results.back() == pend::CaCommand::kAccepted);
  CHECK(fingerprint(console.info()) == kEcFingerprint);
  struct Row { const char* line; pend::CaCommand command; };
  const Row rows[] = {{"ca", pend::CaCommand::kShow}, {"ca show", pend::CaCommand::kShow},
                      {" ca clear ", pend::CaCommand::kClear}, {"ca sett", pend::CaCommand::kRefused},
                      {"show", pend::CaCommand::kNone}, {"set port 8883", pend::CaCommand::kNone},
                      {"cat", pend::CaCommand::kNone}, {"", pend::CaCommand::kNone}};
  for (const Row& row : rows) {
    CAPTURE(row.line);
    CHECK(console.feed(row.line, std::strlen(row.line), 0) == row.command);
  }
  CHECK(console.error() == pend::CaStatus::kUnknownCommand);
}

TEST_CASE("console: a paste that loses a character is refused at once, the rest dropped, nothing kept") {
  pend::CaConsole console;
  Lines lines = split(kRsaCa);
  lines[3].erase(20, 1);  // a serial buffer overflowed
  lines.insert(lines.begin(), "ca set");
  const std::vector<pend::CaCommand> results = feed(console, lines);
  CHECK(results[4] == pend::CaCommand::kTaken);      // the short line itself looks like a last line
  CHECK(results[5] == pend::CaCommand::kRefused);    // the next one gives it away
  CHECK(console.error() == pend::CaStatus::kUnevenLines);
  for (size_t i = 6; i < results.size(); ++i) CHECK(results[i] == pend::CaCommand::kTaken);  // dropped quietly
  CHECK(console.pem_length() == 0);
  CHECK(std::string(console.pem()).empty());
  CHECK(console.feed("show", 4, 0) == pend::CaCommand::kNone);  // the console is back to commands
}

TEST_CASE("console: a command typed mid-paste ends it; the next command is the caller's again") {
  pend::CaConsole console;
  Lines lines = split(kRsaCa);
  lines.resize(5);
  lines.push_back("set port 8883");
  lines.push_back("save");
  const std::vector<pend::CaCommand> results = feed(console, lines);
  CHECK(results[5] == pend::CaCommand::kRefused);
  CHECK(console.error() == pend::CaStatus::kBadCharacter);
  CHECK(results[6] == pend::CaCommand::kNone);  // `save` reaches the caller, and no CA came with it
  CHECK(console.pem_length() == 0);
}

TEST_CASE("console: a private key is refused and its lines never echo back; a new paste right after works") {
  pend::CaConsole console;
  const Lines key = {"-----BEGIN PRIVATE KEY-----", std::string(64, 'Q'), std::string(40, 'Q') + "==",
                     "-----END PRIVATE KEY-----"};
  std::vector<pend::CaCommand> results = feed(console, key);
  CHECK(results == std::vector<pend::CaCommand>{pend::CaCommand::kRefused, pend::CaCommand::kTaken,
                                                pend::CaCommand::kTaken, pend::CaCommand::kTaken});
  CHECK(console.error() == pend::CaStatus::kPrivateKey);
  CHECK(console.feed("ca set", 6, 0) == pend::CaCommand::kStarted);
  CHECK(console.feed(key[0].data(), key[0].size(), 0) == pend::CaCommand::kRefused);
  CHECK(console.error() == pend::CaStatus::kPrivateKey);
  Lines broken = split(kEcCa);
  broken[2] = "not base64!";
  results = feed(console, broken);
  CHECK(results[2] == pend::CaCommand::kRefused);
  results = feed(console, split(kEcCa));  // pasted again at once: its BEGIN is not swallowed with the rest
  CHECK(results.front() == pend::CaCommand::kStarted);
  CHECK(results.back() == pend::CaCommand::kAccepted);
}

TEST_CASE("console: a chain or an oversized paste is refused; a paste holds the link only while it flows") {
  pend::CaConsole console;
  Lines lines = split(kRsaCa);
  lines.insert(lines.begin() + 2, 45, std::string(64, 'A'));
  std::vector<pend::CaCommand> results = feed(console, lines);
  CHECK(std::count(results.begin(), results.end(), pend::CaCommand::kRefused) == 1);
  CHECK(console.error() == pend::CaStatus::kTooLong);
  CHECK(console.feed("ca set", 6, 5000) == pend::CaCommand::kStarted);
  CHECK(console.holds_link(5000 + pend::kPasteQuietMs - 1));
  CHECK_FALSE(console.holds_link(5000 + pend::kPasteQuietMs));  // a paste left half-way does not stop the rig
  CHECK(console.feed("ca", 2, 20000) == pend::CaCommand::kRefused);  // still waiting for BEGIN
  CHECK_FALSE(console.holds_link(20001));
}

TEST_CASE("link: TLS exactly with a CA; port 0 is the transport's usual port; a crossed port gets a hint") {
  struct Row { uint16_t port; bool has_ca; bool tls; uint16_t used; const char* hint; };
  const Row rows[] = {{0, false, false, 1883, nullptr}, {0, true, true, 8883, nullptr},
                      {1883, true, true, 1883, "set port 0"}, {8883, false, false, 8883, "ca set"},
                      {9001, true, true, 9001, nullptr}, {8883, true, true, 8883, nullptr}};
  for (const Row& row : rows) {
    CAPTURE(row.port);
    CAPTURE(row.has_ca);
    const pend::BrokerLink link = pend::plan_broker_link(row.port, row.has_ca);
    CHECK(link.tls == row.tls);
    CHECK(link.port == row.used);
    const char* hint = pend::broker_port_hint(link);
    CHECK((hint == nullptr) == (row.hint == nullptr));
    if (hint && row.hint) CHECK(std::string(hint).find(row.hint) != std::string::npos);
  }
}

TEST_CASE("link: `set port` takes 0 to 65535 and leaves the port alone otherwise") {
  struct Row { const char* text; bool ok; uint16_t port; };
  const Row rows[] = {{"0", true, 0},        {"8883", true, 8883}, {"65535", true, 65535}, {"65536", false, 7},
                      {"", false, 7},        {"-1", false, 7},     {"88a3", false, 7},     {"123456", false, 7},
                      {" 1883", false, 7}};
  for (const Row& row : rows) {
    CAPTURE(row.text);
    uint16_t port = 7;
    CHECK(pend::parse_port(row.text, std::strlen(row.text), port) == row.ok);
    CHECK(port == row.port);
  }
}

TEST_CASE("link: a failed connection's cause in one line") {
  const pend::BrokerLink tls{true, 8883}, plain{false, 1883};
  struct Row { pend::BrokerLink link; int state; int tls_error; const char* text; const char* expect; };
  const Row rows[] = {
      {plain, 4, 0, "", "refused user 'r01' (bad username or password)"},
      {tls, 5, 0, "", "refused user 'r01' (not authorised)"},
      {plain, 3, 0, "", "refused the connection (MQTT code 3)"},
      {plain, -2, 0, "", "no connection to 10.0.0.5:1883"},
      {pend::BrokerLink{false, 8883}, -2, 0, "", "8883 is the TLS port"},
      {plain, -4, 0, "", "never answered the login"},
      {tls, -2, -0x2700, "X509 - Certificate verification failed",
       "did not verify for '10.0.0.5'"},
      {tls, -2, -0x2700, "X509 - Certificate verification failed",
       "[mbedTLS -0x2700: X509 - Certificate verification failed]"},
      {tls, -2, -0x7F00, "", "out of memory for the TLS handshake (31000 bytes of heap free"},
      {tls, -2, -0x0010, "BIGNUM - Memory allocation failed", "out of memory"},
      {tls, -2, -0x0050, "", "10.0.0.5:8883 closed the TLS handshake"},
      {pend::BrokerLink{true, 1883}, -2, -0x7280, "", "closed the TLS handshake: is it the broker's TLS port?"},
      {tls, -2, -0x7780, "", "ended the TLS handshake with an alert"},
      {tls, -2, -1, "", "no TLS connection to 10.0.0.5:8883"},
      {pend::BrokerLink{true, 1883}, -2, 0, "", "set port 0"},
      {tls, -2, -0x2180, "", "a certificate could not be read"},
      {tls, -2, -0x4280, "", "TLS to 10.0.0.5:8883 failed [mbedTLS -0x4280]"},
  };
  for (const Row& row : rows) {
    CAPTURE(row.expect);
    char line[300];
    const size_t n = pend::describe_link_failure("10.0.0.5", row.link, "r01", row.state, row.tls_error, row.text,
                                                 31000, line, sizeof line);
    CHECK(n == std::strlen(line));
    CHECK(std::string(line).find(row.expect) != std::string::npos);
    CHECK(std::strchr(line, '\n') == nullptr);
  }
  char line[300];
  pend::describe_link_failure("h", tls, "r01", -2, -1, "", 0, line, sizeof line);
  CHECK(std::string(line).find("[mbedTLS") == std::string::npos);  // -1 is arduino's own, not an mbedTLS code
  pend::describe_link_failure("h", tls, "r01", -2, -0x7200, "two\nlines", 0, line, sizeof line);
  CHECK(std::strchr(line, '\n') == nullptr);
  char tiny[20];
  CHECK(pend::describe_link_failure("h", tls, "r01", -2, -0x2700, "x", 0, tiny, sizeof tiny) == 19);
  CHECK(std::strlen(tiny) == 19);
}
