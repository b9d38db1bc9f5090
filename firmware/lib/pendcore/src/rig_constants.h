// Generated from pendkit.rig.RigParams by pendkit/firmware_constants.py. Do not edit.
// Rig: Hitec D645MW.
#pragma once

#include <cstdint>

namespace pend {

constexpr int32_t kEncoderCounts = 1024;  // positions per turn (EMS-22A)
constexpr int32_t kEncoderOffsetCounts = 0;  // raw reading with the pendulum hanging
constexpr int32_t kServoMinCounts = 150;  // PCA9685 counts at -90 deg
constexpr int32_t kServoMaxCounts = 450;  // PCA9685 counts at +90 deg
constexpr double kServoCentreCounts = 300.0;  // counts at 0 deg
constexpr int32_t kServoSpanCounts = 300;  // max - min
constexpr double kServoRangeRad = 1.5707963267948966;  // arm angle at either end of the span
constexpr int32_t kSlowStepCounts = 2;  // discrete slow step per acting tick
constexpr int32_t kFastStepCounts = 4;  // discrete fast step per acting tick
constexpr int32_t kPwmPeriodMs = 20;  // servo PWM period (50 Hz)
constexpr int32_t kPwmResolutionCounts = 4096;  // PCA9685 counts per PWM period
constexpr int32_t kStreamingPeriodMs = 25;  // observation period
constexpr int32_t kActingPeriodMs = 10;  // acting period
constexpr int32_t kVelocityWindow = 4;  // velocities averaged
constexpr double kOverspinLimitRevS = 2.0;  // hold the servo above this spin
constexpr double kWatchdogTimeoutMs = 150.0;  // hold the servo without commands
constexpr int32_t kStuckBadFrames = 8;  // bad SSI frames in a row: stuck encoder
constexpr int32_t kStuckTravelCounts = 60;  // servo travel without an encoder change: stuck

}  // namespace pend
