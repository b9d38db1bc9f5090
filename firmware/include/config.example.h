// Copy to config.h (git-ignored) and fill in. These are only first-boot defaults: the serial console
// (`set ssid ...`, `set host ...`, `ca set`, `save`) stores new values in flash, and they win from then on.
#pragma once

#define PEND_WIFI_SSID "your-network"
#define PEND_WIFI_PASSWORD "your-password"
// With a CA (below) the rig checks that the broker's certificate names this host: use an address or name
// listed in the broker's server-names.txt (`pendkit broker-config --tls` writes it).
#define PEND_MQTT_HOST "192.168.1.10"
#define PEND_MQTT_PORT 0  // 0: 8883 with a CA (TLS), 1883 without
#define PEND_MQTT_USER "r01"
#define PEND_MQTT_PASSWORD "change-me"
#define PEND_RIG_ID "r01"

// The classroom CA (broker/ca.crt) for TLS; empty: plain MQTT, and the password crosses the WiFi in clear.
// Paste the file whole into a raw string, then point PEND_MQTT_CA at it:
//   static const char kClassroomCa[] = R"(-----BEGIN CERTIFICATE-----
//   MIIDFTCCAf2gAwIBAgIUAtBL6pTLBjQ81OkmZrRm964CPDkwDQYJKoZIhvcNAQEL
//   ...
//   -----END CERTIFICATE-----
//   )";
//   #define PEND_MQTT_CA kClassroomCa
// or set it later from the serial console: `ca set`, paste broker/ca.crt, `save`.
#define PEND_MQTT_CA ""
