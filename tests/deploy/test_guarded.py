"""Lab 09's guarded run: the watchdog is asked before every step, its reason ends the run at once and the
servo is told to hold where it is; a quiet watchdog lets the run go to its end."""

import gymnasium
import numpy as np
import pytest

import pendkit
from pendkit.deploy import run_guarded


def push_right(observation, state):
    return np.array([1.0], dtype=np.float32)


class SentActions(gymnasium.Wrapper):
    def __init__(self, env):
        super().__init__(env)
        self.sent, self.targets = [], []

    def step(self, action):
        result = super().step(action)
        self.sent.append(float(np.asarray(action).reshape(-1)[0]))
        self.targets.append(result[4]["state"].servo_target_rad)
        return result


def test_a_watchdogs_reason_stops_the_run_and_the_servo_holds():
    env = SentActions(pendkit.make(action_mode="continuous", filter_coefficient=0.0, start="rest"))
    asked = []

    def watchdog(arm_rad, rate_rad_s, age_s):
        asked.append(arm_rad)
        return "arm past 0.3 rad" if arm_rad > 0.3 else None

    ramp = iter(np.linspace(0.05, 1.0, 200))
    run = run_guarded(env, lambda observation, state: np.array([next(ramp)], dtype=np.float32), watchdog,
                      steps=200, seed=0)
    assert run.stop_reason == "arm past 0.3 rad" and run.trace.stopped_by == run.stop_reason
    # simulated seconds of the seeded twin (not wall time): the stop came inside the run, at a checked step
    assert 0 < run.stopped_at_s < 200 * env.unwrapped.dt and len(asked) == len(run.trace.time_s)
    # the ramp's last target, then one command: hold the target the servo had when the watchdog spoke
    # (the ramp would have gone on up)
    assert env.sent[-1] == pytest.approx(env.sent[-2]) and next(ramp) > env.sent[-1]
    assert env.sent[-1] * env.unwrapped.params.servo_range_rad == pytest.approx(env.targets[-2], abs=1e-6)


def test_a_quiet_watchdog_lets_the_run_reach_its_steps():
    env = pendkit.make(action_mode="continuous", filter_coefficient=0.0, start="rest")
    run = run_guarded(env, push_right, lambda *reading: None, steps=40, seed=0)
    assert run.stop_reason is None and len(run.trace.time_s) == 41
