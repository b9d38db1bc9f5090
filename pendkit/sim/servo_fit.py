"""The twin fitted to a rig's servo step log: the rated speed that makes the twin's slew match the rig's."""

from __future__ import annotations

import math

from pendkit.control.sysid import identify_servo_steps
from pendkit.errors import ConfigError
from pendkit.rig import RigParams
from pendkit.sim.lab_readings import servo_step_readings


def match_servo_speed(measured_slew_rad_s: float, params=None, steps_rad=(0.6, -0.6, 0.2)):
    """`params` with the servo's rated speed (`servo_speed_s_per_60deg`) set so that the twin's 10-90 %
    slew on the same command steps matches `measured_slew_rad_s`: the twin fitted to a step log.

    The 10-90 % slope is below the rated speed (the arm accelerates and settles inside it), so the
    rated speed is found by simulating, not by converting: bisection on the twin's own step response.
    """
    params = params or RigParams()
    if not (math.isfinite(measured_slew_rad_s) and measured_slew_rad_s > 0):
        raise ConfigError(f"the measured slew rate must be a positive number of rad/s, got {measured_slew_rad_s}")

    def slew(s_per_60deg: float) -> float:
        readings = servo_step_readings(steps_rad, params=params.replace(servo_speed_s_per_60deg=s_per_60deg))
        return identify_servo_steps(readings.times_s, readings.commanded_rad, readings.arm_rad).slew_rate_rad_s

    fast, slow = 0.05, 1.0  # s per 60 degrees: faster than any hobby servo, and far slower
    if not slew(slow) <= measured_slew_rad_s <= slew(fast):
        raise ConfigError(f"a slew of {measured_slew_rad_s:.2f} rad/s is outside what a hobby servo on this rig "
                          f"can show ({slew(slow):.2f}-{slew(fast):.2f} rad/s)")
    for _ in range(30):
        middle = (fast + slow) / 2
        fast, slow = (middle, slow) if slew(middle) > measured_slew_rad_s else (fast, middle)
    return params.replace(servo_speed_s_per_60deg=round((fast + slow) / 2, 4))
