"""The twin's device stops the physics only where the device meets it: an action's arrival is taken at the next
PWM frame or reading, in time order with the acting ticks, and nothing a policy or a test sees changes."""

from __future__ import annotations

import dataclasses

import mujoco
import pytest

import pendkit
from pendkit.network import IMPAIRMENTS
from pendkit.sim import twin_device
from pendkit.sim.fidelity import FIDELITY_PRESETS

STEPS = 400


def _run(action_mode: str) -> list:
    fidelity = dataclasses.replace(FIDELITY_PRESETS["realistic"], network=IMPAIRMENTS["poor-wifi"])
    env = pendkit.make(fidelity=fidelity, action_mode=action_mode)
    env.reset(seed=4)
    env.action_space.seed(4)
    seen = []
    for _ in range(STEPS):
        observation, reward, terminated, truncated, info = env.step(env.action_space.sample())
        seen.append((observation.tolist(), reward, info["servo_target_rad"], info["true_state"]))
        if terminated or truncated:
            env.reset()
    env.close()
    return seen


@pytest.mark.parametrize("action_mode", ["discrete", "continuous"])
def test_actions_taken_at_the_next_event_change_nothing_and_stop_the_physics_less(monkeypatch, action_mode):
    calls = [0]
    real_step = mujoco.mj_step

    def counting_step(model, data, nstep=1):
        calls[0] += 1
        real_step(model, data, nstep)

    monkeypatch.setattr(mujoco, "mj_step", counting_step)
    deferred = _run(action_mode)
    stops_deferred, calls[0] = calls[0], 0
    monkeypatch.setattr(twin_device, "WAITS_FOR_NEXT_EVENT", frozenset())  # every arrival stops the physics
    at_arrival = _run(action_mode)
    stops_at_arrival = calls[0]
    assert deferred == at_arrival
    assert stops_deferred < stops_at_arrival
    # 60 ms steps: three PWM frames and 2.4 readings (0.6 of them on a frame) leave 4.8 stops a step
    assert stops_deferred / STEPS == pytest.approx(4.8, abs=0.2)
