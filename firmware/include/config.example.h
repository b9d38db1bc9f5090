// Copy to config.h (git-ignored) and fill in. These are only first-boot defaults: the serial console
// (`set ssid ...`, `set broker ...`, `save`) stores new values in flash, and they win from then on.
#pragma once

#define PEND_WIFI_SSID "your-network"
#define PEND_WIFI_PASSWORD "your-password"
#define PEND_MQTT_HOST "192.168.1.10"
#define PEND_MQTT_PORT 1883
#define PEND_MQTT_USER "r01"
#define PEND_MQTT_PASSWORD "change-me"
#define PEND_RIG_ID "r01"
