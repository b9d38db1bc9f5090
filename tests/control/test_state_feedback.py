"""A hand-designed gain drives the twin by itself (lab 04's balance plot): a right K balances, a wrong one
falls, and what the closed-loop poles say is what the twin does."""

import math

import control
import numpy as np
import pytest

import pendkit
from pendkit.control.lqr import StateFeedback
from pendkit.control.model import FurutaModel, discretise
from pendkit.episode import run_episode
from pendkit.errors import ConfigError

START = {"start": "rest", "pendulum_angle_rad": math.pi + math.radians(10)}


def design(q_diagonal=(2.0, 40.0, 0.05, 0.5), r=3.0):
    discrete = discretise(FurutaModel.from_rig().linearise("upright"), 0.06)
    gain, _, _ = control.dlqr(discrete.A, discrete.B, np.diag(q_diagonal), [[r]])
    poles = np.linalg.eigvals(discrete.A - discrete.B @ gain)
    return np.asarray(gain), float(np.max(np.abs(poles)))


def final_error_deg(gain) -> float:
    env = pendkit.make(action_mode="continuous", fidelity="ideal", filter_coefficient=0.0)
    trace = run_episode(env, StateFeedback(gain, env.unwrapped.params), seed=0, steps=120, options=START)
    return float(np.degrees(np.max(np.abs(trace.pendulum_from_upright_rad[-40:]))))


def test_a_designed_gain_balances_the_twin_and_its_poles_said_so():
    gain, largest_pole = design()
    assert largest_pole < 1
    assert final_error_deg(gain) < 0.5


@pytest.mark.parametrize("mistake", ["sign", "no pendulum feedback", "hanging model"])
def test_a_wrong_gain_falls_over(mistake):
    gain, _ = design()
    if mistake == "sign":  # A + BK
        wrong = -gain
    elif mistake == "no pendulum feedback":
        wrong = gain * np.array([1.0, 0.0, 1.0, 0.0])
    else:  # designed on the model about the bottom: stable there, useless upright
        discrete = discretise(FurutaModel.from_rig().linearise("hanging"), 0.06)
        wrong = np.asarray(control.dlqr(discrete.A, discrete.B, np.diag([2.0, 40.0, 0.05, 0.5]), [[3.0]])[0])
    upright = discretise(FurutaModel.from_rig().linearise("upright"), 0.06)
    assert np.max(np.abs(np.linalg.eigvals(upright.A - upright.B @ wrong.reshape(1, 4)))) > 1
    assert final_error_deg(wrong) > 45


@pytest.mark.parametrize("gain", [[1.0, 2.0, 3.0], [[1.0, 2.0], [3.0, 4.0]], [1.0, float("nan"), 0.0, 0.0], "K"])
def test_a_malformed_gain_is_refused_with_its_shape(gain):
    with pytest.raises(ConfigError, match="4 .*numbers"):
        StateFeedback(gain)
