// The one pin map. Check it against your board's pinout before wiring (docs/build-guide.md).
#pragma once

#include <cstdint>

namespace pins {

// EMS-22A absolute encoder, bit-banged SSI (5 V part: power it from 5 V, its DO needs a divider to 3.3 V).
constexpr uint8_t kEncoderClock = 10;
constexpr uint8_t kEncoderData = 11;
constexpr uint8_t kEncoderChipSelect = 12;

// PCA9685 servo driver on I2C (the Thing Plus's Qwiic connector).
constexpr uint8_t kI2cSda = 1;
constexpr uint8_t kI2cScl = 2;
constexpr uint8_t kServoChannel = 0;
constexpr uint8_t kServoDriverAddress = 0x40;

}  // namespace pins
