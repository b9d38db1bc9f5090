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

// An observer model's physical ranges (pendkit/device/physical_ranges.py), in MODEL_FIELDS' order:
// arm, pendulum and long-axis inertias, coupling, gravity torque, pendulum and arm damping, kp, kv,
// stall torque, servo range
constexpr double kObserverModelMin[11] = {
    0.00023661249672060004, 2.06311460355e-05, 2.587997412e-08, 0.0,
    0.0005830077169917, 0.0, 0.0, 0.12702805389909338,
    0.0, 0.011085288914700002, 0.017453275066650776,
};
constexpr double kObserverModelMax[11] = {
    2.3661296994606666, 0.2063118729783333, 0.0002588002588, 0.2525777525775,
    5.8300888300830005, 1.000001, 21.17138465924254, 1270.2830795545524,
    55.582005244152015, 110.85311085300002, 3.1415957951824462,
};
// A swing-up blob's scalars' ranges, in SCALARS' order (pendkit/device/swingup_blob.py): its model's
// terms physical, its gains any finite float
constexpr double kSwingUpScalarMin[24] = {
    -3.4028234663852886e+38, -3.4028234663852886e+38, -3.4028234663852886e+38, -3.4028234663852886e+38,
    0.053158784346306755, -3.4028234663852886e+38, -3.4028234663852886e+38, -3.4028234663852886e+38,
    -3.4028234663852886e+38, -3.4028234663852886e+38, -3.4028234663852886e+38, -3.4028234663852886e+38,
    -3.4028234663852886e+38, -3.4028234663852886e+38, 0.017453275066650776, -3.4028234663852886e+38,
    -3.4028234663852886e+38, -3.4028234663852886e+38, 0.05368600627769815, 0.0,
    0.0, 0.004684987858960889, 0.0, 0.0,
};
constexpr double kSwingUpScalarMax[24] = {
    3.4028234663852886e+38, 3.4028234663852886e+38, 3.4028234663852886e+38, 3.4028234663852886e+38,
    531.5889066398177, 3.4028234663852886e+38, 3.4028234663852886e+38, 3.4028234663852886e+38,
    3.4028234663852886e+38, 3.4028234663852886e+38, 3.4028234663852886e+38, 3.4028234663852886e+38,
    3.4028234663852886e+38, 3.4028234663852886e+38, 3.1415957951824462, 3.4028234663852886e+38,
    3.4028234663852886e+38, 3.4028234663852886e+38, 5368622.102215274, 234907.3105373006,
    89477.03503692124, 468500.65989498043, 12242.545913004038, 48470.45327871262,
};

}  // namespace pend
