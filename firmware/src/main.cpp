// Wires the hardware to the portable core: WiFi, MQTT, the PCA9685 and the EMS-22A. All logic lives in
// lib/pendcore (host-tested); this file only moves bytes and pins.
#include <Adafruit_PWMServoDriver.h>
#include <Arduino.h>
#include <Preferences.h>
#include <PubSubClient.h>
#include <WiFi.h>
#include <Wire.h>

#include "config.h"
#include "device.h"
#include "pins.h"
#include "protocol.h"
#include "scheduler.h"

namespace {

constexpr const char* kFirmwareVersion = "0.1.0";

struct Settings {
  String ssid, password, host, user, mqtt_password, rig;
  uint16_t port;
};

Settings settings;
Preferences preferences;
WiFiClient network;
PubSubClient mqtt(network);
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
  preferences.end();
  topic_obs = "pendulum-r/obs/" + settings.rig;
  topic_act = "pendulum-r/act/" + settings.rig;
  topic_status = "pendulum-r/status/" + settings.rig;
  topic_ctl = "pendulum-r/ctl/" + settings.rig;  // controller uploads, binary chunks (docs/on-device.md)
}

// Serial provisioning: `set <key> <value>` for ssid, password, host, port, user, mqtt_password, rig;
// `save` stores them and restarts; `show` prints them (passwords masked).
void handle_serial_line(const String& line) {
  if (line == "show") {
    Serial.printf("ssid=%s host=%s:%u user=%s rig=%s\n", settings.ssid.c_str(), settings.host.c_str(),
                  settings.port, settings.user.c_str(), settings.rig.c_str());
  } else if (line == "save") {
    preferences.begin("pendkit", false);
    preferences.putString("ssid", settings.ssid);
    preferences.putString("password", settings.password);
    preferences.putString("host", settings.host);
    preferences.putUShort("port", settings.port);
    preferences.putString("user", settings.user);
    preferences.putString("mqtt_password", settings.mqtt_password);
    preferences.putString("rig", settings.rig);
    preferences.end();
    Serial.println("saved; restarting");
    ESP.restart();
  } else if (line.startsWith("set ")) {
    const int space = line.indexOf(' ', 4);
    const String key = line.substring(4, space), value = space > 0 ? line.substring(space + 1) : "";
    if (key == "ssid") settings.ssid = value;
    else if (key == "password") settings.password = value;
    else if (key == "host") settings.host = value;
    else if (key == "port") settings.port = static_cast<uint16_t>(value.toInt());
    else if (key == "user") settings.user = value;
    else if (key == "mqtt_password") settings.mqtt_password = value;
    else if (key == "rig") settings.rig = value;
    else Serial.println("unknown key");
  } else if (line.length() > 0) {
    Serial.println("commands: show | set <key> <value> | save");
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

void keep_connected() {
  if (WiFi.status() != WL_CONNECTED || mqtt.connected()) return;
  const String client_id = "pendkit-" + settings.rig;
  // Last will: if the link drops, the broker tells everyone the rig is offline.
  if (mqtt.connect(client_id.c_str(), settings.user.c_str(), settings.mqtt_password.c_str(),
                   topic_status.c_str(), 1, true, "{\"online\":false}")) {
    network.setNoDelay(true);  // no Nagle: 13-32 ms p99 latency otherwise
    // Clear a command left retained on our topic before subscribing: it would move the arm at every boot
    // (the classroom ACL lets a rig write its own command topic for this).
    mqtt.publish(topic_act.c_str(), reinterpret_cast<const uint8_t*>(""), 0, true);
    mqtt.subscribe(topic_act.c_str());
    mqtt.subscribe(topic_ctl.c_str());
    publish_status();
  }
}

}  // namespace

void setup() {
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
  WiFi.begin(settings.ssid.c_str(), settings.password.c_str());
  mqtt.setServer(settings.host.c_str(), settings.port);
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
