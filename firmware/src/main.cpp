// Wires the hardware to the portable core: WiFi, MQTT (over TLS when the rig has the classroom CA), the PCA9685
// and the EMS-22A. All logic lives in lib/pendcore (host-tested); this file only moves bytes and pins.
#include <Adafruit_PWMServoDriver.h>
#include <Arduino.h>
#include <Preferences.h>
#include <PubSubClient.h>
#include <WiFi.h>
#include <WiFiClientSecure.h>
#include <Wire.h>

#include "broker_tls.h"
#include "config.h"
#include "device.h"
#include "pins.h"
#include "protocol.h"
#include "scheduler.h"

// A config.h written before TLS has no CA: plain MQTT, as before.
#ifndef PEND_MQTT_CA
#define PEND_MQTT_CA ""
#endif

namespace {

constexpr const char* kFirmwareVersion = "0.1.0";

struct Settings {
  String ssid, password, host, user, mqtt_password, rig, ca;  // ca: the classroom CA's PEM, empty for plain MQTT
  uint16_t port;  // 0: the usual port (8883 with a CA, 1883 without)
};

Settings settings;  // what the console edits; `save` stores it and restarts
Preferences preferences;
// What the link uses, fixed at boot: PubSubClient and WiFiClientSecure keep these pointers, so console edits
// must not move them. The TLS check compares active_host with the names in the broker's certificate.
String active_host, active_ca;
pend::BrokerLink broker_link{false, pend::kMqttPlainPort};
bool link_allowed = true;  // false with a broken stored CA: never fall back to sending the password in clear
WiFiClient plain_network;
WiFiClientSecure* tls_network = nullptr;  // made only when the rig has a CA (its context takes heap)
PubSubClient mqtt;
pend::CaConsole ca_console;
pend::Schedule reconnect(pend::kReconnectPeriodMs);
String last_failure;  // printed once until the cause changes
Adafruit_PWMServoDriver servo_driver(pins::kServoDriverAddress);
pend::Scheduler scheduler;  // the device's logic and its loop: all of it in lib/pendcore, host-tested
String topic_obs, topic_act, topic_status, topic_ctl;

void load_settings() {
  preferences.begin("pendkit", true);
  settings.ssid = preferences.getString("ssid", PEND_WIFI_SSID);
  settings.password = preferences.getString("password", PEND_WIFI_PASSWORD);
  settings.host = preferences.getString("host", PEND_MQTT_HOST);
  settings.port = preferences.getUShort("port", PEND_MQTT_PORT);
  settings.user = preferences.getString("user", PEND_MQTT_USER);
  settings.mqtt_password = preferences.getString("mqtt_password", PEND_MQTT_PASSWORD);
  settings.rig = preferences.getString("rig", PEND_RIG_ID);
  settings.ca = preferences.getString("ca", PEND_MQTT_CA);
  preferences.end();
  topic_obs = "pendulum-r/obs/" + settings.rig;
  topic_act = "pendulum-r/act/" + settings.rig;
  topic_status = "pendulum-r/status/" + settings.rig;
  topic_ctl = "pendulum-r/ctl/" + settings.rig;  // controller uploads, binary chunks (docs/on-device.md)
}

void show_ca() {
  if (settings.ca.length() == 0) {
    Serial.println("ca: none: plain MQTT (`ca set`, then paste broker/ca.crt, for TLS)");
  } else {
    pend::CaInfo info;
    const pend::CaStatus status = pend::check_ca_pem(settings.ca.c_str(), settings.ca.length(), info);
    char fingerprint[96];
    if (status != pend::CaStatus::kOk || pend::format_fingerprint(info, fingerprint, sizeof fingerprint) == 0) {
      Serial.printf("ca: stored but broken: %s\n", pend::ca_status_message(status));
    } else {
      Serial.printf("ca: sha256 %s (%u bytes): TLS, the broker's certificate must name host\n", fingerprint,
                    static_cast<unsigned>(info.der_bytes));
    }
  }
  if (settings.ca != active_ca) Serial.println("ca: changed but not in use yet: `save` stores it and restarts");
}

// The classroom CA from the console: `ca` shows it, `ca set` then a paste of broker/ca.crt replaces it (only
// once the whole certificate checks out), `ca clear` removes it. True when the line was the CA's.
bool handle_ca_line(const String& line) {
  switch (ca_console.feed(line.c_str(), line.length(), millis())) {
    case pend::CaCommand::kNone: return false;
    case pend::CaCommand::kShow: show_ca(); break;
    case pend::CaCommand::kClear:
      settings.ca = "";
      Serial.println("ca: cleared: plain MQTT after `save`");
      break;
    case pend::CaCommand::kStarted:
      Serial.println("ca: paste broker/ca.crt, BEGIN line to END line (no connection attempts meanwhile)");
      break;
    case pend::CaCommand::kTaken: break;
    case pend::CaCommand::kAccepted: {
      settings.ca = ca_console.pem();
      char fingerprint[96];
      pend::format_fingerprint(ca_console.info(), fingerprint, sizeof fingerprint);
      Serial.printf("ca: accepted, sha256 %s: `save` to use it\n", fingerprint);
      const char* hint = pend::broker_port_hint(pend::plan_broker_link(settings.port, true));
      if (hint) Serial.printf("ca: %s\n", hint);
      break;
    }
    case pend::CaCommand::kRefused:
      Serial.printf("ca: refused, nothing changed: %s\n", pend::ca_status_message(ca_console.error()));
      break;
  }
  return true;
}

// Serial provisioning: `set <key> <value>` for ssid, password, host, port, user, mqtt_password, rig; the `ca`
// commands; `save` stores them and restarts; `show` prints them (passwords masked) and the heap.
void handle_serial_line(const String& line) {
  if (handle_ca_line(line)) return;
  if (line == "show") {
    const pend::BrokerLink planned = pend::plan_broker_link(settings.port, settings.ca.length() > 0);
    Serial.printf("ssid=%s host=%s port=%u (%s://%s:%u) user=%s rig=%s\n", settings.ssid.c_str(),
                  settings.host.c_str(), settings.port, planned.tls ? "mqtts" : "mqtt", settings.host.c_str(),
                  planned.port, settings.user.c_str(), settings.rig.c_str());
    show_ca();
    Serial.printf("heap: %u bytes free, %u the lowest since boot, %u the largest block\n",
                  static_cast<unsigned>(ESP.getFreeHeap()), static_cast<unsigned>(ESP.getMinFreeHeap()),
                  static_cast<unsigned>(ESP.getMaxAllocHeap()));
  } else if (line == "save") {
    preferences.begin("pendkit", false);
    preferences.putString("ssid", settings.ssid);
    preferences.putString("password", settings.password);
    preferences.putString("host", settings.host);
    preferences.putUShort("port", settings.port);
    preferences.putString("user", settings.user);
    preferences.putString("mqtt_password", settings.mqtt_password);
    preferences.putString("rig", settings.rig);
    const bool ca_stored = preferences.putString("ca", settings.ca) == settings.ca.length();
    preferences.end();
    if (!ca_stored) {  // NVS keeps strings up to 4000 bytes; the console accepts 3000
      Serial.println("save: the CA could not be stored; not restarting");
      return;
    }
    Serial.println("saved; restarting");
    ESP.restart();
  } else if (line.startsWith("set ")) {
    const int space = line.indexOf(' ', 4);
    const String key = line.substring(4, space), value = space > 0 ? line.substring(space + 1) : "";
    if (key == "ssid") settings.ssid = value;
    else if (key == "password") settings.password = value;
    else if (key == "host") settings.host = value;
    else if (key == "port") {
      if (!pend::parse_port(value.c_str(), value.length(), settings.port)) {
        Serial.println("port: 0 (8883 with a CA, 1883 without) or 1 to 65535");
      }
    } else if (key == "user") settings.user = value;
    else if (key == "mqtt_password") settings.mqtt_password = value;
    else if (key == "rig") settings.rig = value;
    else Serial.println("unknown key");
  } else if (line.length() > 0) {
    Serial.println("commands: show | set <key> <value> | save | ca | ca set | ca clear");
  }
}

void publish_status() {
  char json[640];  // the status with its controller object
  if (scheduler.status_json(kFirmwareVersion, settings.rig.c_str(), json, sizeof json) > 0) {
    mqtt.publish(topic_status.c_str(), json, true);  // retained: a newcomer sees the rig's state at once
  }
}

// Commands and upload chunks take the same path: the core tells them apart by the chunk's magic.
void on_command(char*, uint8_t* payload, unsigned int length) {
  scheduler.receive(reinterpret_cast<const char*>(payload), length, millis());
  if (scheduler.take_status_request()) publish_status();
}

// EMS-22A over SSI: chip select low, then 16 clock pulses; the encoder shifts a bit out on each rising
// edge, read just after it, most significant bit first.
int64_t read_encoder_frame() {
  digitalWrite(pins::kEncoderChipSelect, LOW);
  delayMicroseconds(1);
  uint32_t frame = 0;
  for (int bit = 0; bit < 16; ++bit) {
    digitalWrite(pins::kEncoderClock, LOW);
    delayMicroseconds(1);
    digitalWrite(pins::kEncoderClock, HIGH);
    delayMicroseconds(1);
    frame = (frame << 1) | static_cast<uint32_t>(digitalRead(pins::kEncoderData));
  }
  digitalWrite(pins::kEncoderChipSelect, HIGH);
  return frame;
}

// A connection attempt every kReconnectPeriodMs at most: over TLS each one blocks the loop for a handshake.
void keep_connected() {
  const uint32_t now_ms = millis();
  if (!link_allowed || WiFi.status() != WL_CONNECTED || mqtt.connected()) return;
  if (ca_console.holds_link(now_ms) || !reconnect.due(now_ms)) return;
  const String client_id = "pendkit-" + settings.rig;
  // Last will: if the link drops, the broker tells everyone the rig is offline.
  if (mqtt.connect(client_id.c_str(), settings.user.c_str(), settings.mqtt_password.c_str(),
                   topic_status.c_str(), 1, true, "{\"online\":false}")) {
    // No Nagle: 13-32 ms p99 latency otherwise (the TLS client sets TCP_NODELAY on its own socket).
    if (!broker_link.tls) plain_network.setNoDelay(true);
    Serial.printf("mqtt: connected to %s:%u (%s) in %u ms; heap %u bytes free, %u the lowest since boot\n",
                  active_host.c_str(), broker_link.port, broker_link.tls ? "TLS" : "plain MQTT",
                  static_cast<unsigned>(millis() - now_ms), static_cast<unsigned>(ESP.getFreeHeap()),
                  static_cast<unsigned>(ESP.getMinFreeHeap()));
    last_failure = "";
    // Clear a command left retained on our topic before subscribing: it would move the arm at every boot
    // (the classroom ACL lets a rig write its own command topic for this).
    mqtt.publish(topic_act.c_str(), reinterpret_cast<const uint8_t*>(""), 0, true);
    mqtt.subscribe(topic_act.c_str());
    mqtt.subscribe(topic_ctl.c_str());
    publish_status();
  } else {
    char tls_text[100] = "";
    const int tls_error = tls_network ? tls_network->lastError(tls_text, sizeof tls_text) : 0;
    char cause[300];
    pend::describe_link_failure(active_host.c_str(), broker_link, settings.user.c_str(), mqtt.state(), tls_error,
                                tls_text, ESP.getFreeHeap(), cause, sizeof cause);
    if (last_failure != cause) Serial.println(cause);
    last_failure = cause;
  }
}

// The transport, fixed for this boot: TLS with the stored CA (verified: the broker's certificate must chain to
// it and name active_host; never setInsecure), plain MQTT without one.
void set_up_link() {
  active_host = settings.host;
  active_ca = settings.ca;
  broker_link = pend::plan_broker_link(settings.port, active_ca.length() > 0);
  if (broker_link.tls) {
    pend::CaInfo info;
    const pend::CaStatus status = pend::check_ca_pem(active_ca.c_str(), active_ca.length(), info);
    if (status != pend::CaStatus::kOk) {
      link_allowed = false;
      Serial.printf("ca: the stored CA is broken (%s): not connecting; `ca set` it again or `ca clear`, then "
                    "`save`\n", pend::ca_status_message(status));
      return;
    }
    tls_network = new WiFiClientSecure();
    tls_network->setCACert(active_ca.c_str());
    tls_network->setHandshakeTimeout(pend::kTlsHandshakeTimeoutS);
    mqtt.setClient(*tls_network);
  } else {
    mqtt.setClient(plain_network);
  }
  if (const char* hint = pend::broker_port_hint(broker_link)) Serial.printf("mqtt: %s\n", hint);
  mqtt.setServer(active_host.c_str(), broker_link.port);
}

}  // namespace

void setup() {
  Serial.setRxBufferSize(1024);  // a pasted CA arrives faster than a loop busy connecting reads it
  Serial.begin(115200);
  pinMode(pins::kEncoderClock, OUTPUT);
  pinMode(pins::kEncoderChipSelect, OUTPUT);
  pinMode(pins::kEncoderData, INPUT);
  digitalWrite(pins::kEncoderClock, HIGH);
  digitalWrite(pins::kEncoderChipSelect, HIGH);
  Wire.begin(pins::kI2cSda, pins::kI2cScl);
  servo_driver.begin();
  servo_driver.setPWMFreq(1000 / pend::kPwmPeriodMs);
  servo_driver.setPWM(pins::kServoChannel, 0, static_cast<uint16_t>(scheduler.device().servo_counts()));
  load_settings();
  set_up_link();
  WiFi.begin(settings.ssid.c_str(), settings.password.c_str());
  mqtt.setCallback(on_command);
  mqtt.setBufferSize(1200);  // an upload chunk: 12 bytes of header, 1024 of blob, the topic
}

// The encoder as the onboard controller reads it on an acting tick; -1 for a bad frame (the streaming
// tick counts bad frames and the stuck-encoder stop holds the servo).
int32_t encoder_for_controller() {
  if (!scheduler.device().onboard().running()) return -1;
  const int64_t frame = read_encoder_frame();
  return pend::frame_status(frame) == pend::FrameStatus::kOk ? pend::frame_position(static_cast<uint32_t>(frame)) : -1;
}

void loop() {
  static String serial_line;
  while (Serial.available()) {
    const char c = static_cast<char>(Serial.read());
    if (c == '\n') {
      serial_line.trim();
      handle_serial_line(serial_line);
      serial_line = "";
    } else if (serial_line.length() < 128) {
      serial_line += c;
    }
  }
  keep_connected();
  mqtt.loop();
  const uint32_t now = millis();
  // The core holds the servo itself when commands stop (watchdog), so a lost link is safe.
  if (scheduler.acting_due(now)) {
    const int32_t counts = scheduler.device().act(now, encoder_for_controller());
    servo_driver.setPWM(pins::kServoChannel, 0, static_cast<uint16_t>(counts));
  }
  if (scheduler.streaming_due(now)) {
    const pend::Observation observation = scheduler.device().stream_frame(read_encoder_frame(), now);
    char line[96];
    if (scheduler.observation_line(observation, line, sizeof line) > 0 && mqtt.connected()) {
      mqtt.publish(topic_obs.c_str(), line);
    }
  }
}
