"""The firmware's faster, less lagged stream (`u10`, `n2`), as the twin models it: a rate closer to the
pendulum's, readings fresher, and the device command that switches the window."""

import numpy as np
import pytest

import pendkit
from pendkit.device.commands import parse_command
from pendkit.device.logic import McuLogic
from pendkit.rig import FAST_STREAM, RigParams


def rate_error_rms(params: RigParams) -> float:
    env = pendkit.make(fidelity="realistic", params=params, start="rest")
    env.reset(seed=0, options={"pendulum_angle_rad": 2.5})
    errors = []
    for _ in range(150):  # a free swing with the arm held
        observation, _, _, _, info = env.step(0)
        errors.append(observation[2] - info["true_state"]["pendulum_velocity_rad_s"])
    return float(np.sqrt(np.mean(np.square(errors))))


def test_fast_stream_reports_a_rate_closer_to_the_pendulums():
    paper, fast = rate_error_rms(RigParams()), rate_error_rms(RigParams(**FAST_STREAM))
    assert fast < 0.6 * paper, (fast, paper)


def test_velocity_window_command_restarts_a_shorter_mean():
    mcu = McuLogic(RigParams())
    for k in range(6):
        mcu.streaming_tick(10 * k, 25 * k)
    steady = mcu.omega_rev_s
    mcu.apply(parse_command("#3:n1"), 150)
    first = mcu.streaming_tick(60, 150).omega_rev_s  # the new history starts: no previous reading yet
    second = mcu.streaming_tick(80, 175).omega_rev_s  # one interval: 20 counts in 25 ms, not averaged
    assert steady == pytest.approx(10 / 1024 / 0.025)
    assert first == 0.0 and second == pytest.approx(20 / 1024 / 0.025)
    with pytest.raises(Exception, match="out_of_range"):
        parse_command("n17")
