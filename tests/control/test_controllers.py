"""LQR balance and energy swing-up on the nonlinear twin."""

import math

import control
import numpy as np
import pytest

import pendkit
from pendkit.control.lqr import LqrBalancer, LqrWeights, lqr_gain
from pendkit.control.swingup import SwingUpConfig, SwingUpController
from pendkit.episode import run_episode, time_to_upright_s
from pendkit.errors import ConfigError
from pendkit.features import pendulum_energy


@pytest.mark.parametrize("fidelity", ["ideal", "paper-delayed", "realistic"])
@pytest.mark.parametrize("env_filter", [0.85, 0.0])
def test_lqr_balances_from_15_degrees(fidelity, env_filter):
    for seed, side in ((0, -1), (1, 1), (2, -1), (3, 1)):
        env = pendkit.make(action_mode="continuous", fidelity=fidelity, filter_coefficient=env_filter)
        trace = run_episode(env, LqrBalancer.for_env(env), seed=seed, steps=200,
                            options={"start": "rest", "pendulum_angle_rad": math.pi + side * math.radians(15)})
        angles = np.abs(trace.pendulum_from_upright_rad)
        assert angles[-100:].max() < 0.1, f"seed {seed}: still {angles[-100:].max():.2f} rad off at the end"


def test_lqr_design_is_stable_and_uses_python_control():
    balancer = LqrBalancer()
    assert np.all(np.abs(balancer.closed_loop_poles) < 1)
    a, b = np.asarray(balancer.system.A), np.asarray(balancer.system.B)
    gain, _, _ = control.dlqr(a, b, balancer.weights.q_matrix(), [[balancer.weights.action]])
    np.testing.assert_allclose(balancer.gain, gain)


@pytest.mark.parametrize("weights, words", [
    ({"pendulum_angle": -1.0}, "pendulum_angle must be finite and >= 0"),
    ({"action": 0.0}, "action must be > 0"),
    ({"arm_angle": float("nan")}, "arm_angle"),
])
def test_bad_weights_are_refused(weights, words):
    with pytest.raises(ConfigError, match=words):
        LqrWeights(**weights)


def test_unstabilisable_designs_are_refused():
    system = LqrBalancer().system
    no_input = control.ss(system.A, np.zeros_like(system.B), system.C, system.D, system.dt)
    with pytest.raises(ConfigError, match="not stabilisable"):
        lqr_gain(no_input, np.eye(5), np.eye(1))
    with pytest.raises(ConfigError, match="positive semidefinite"):
        lqr_gain(system, -np.eye(5), np.eye(1))
    with pytest.raises(ConfigError, match="Q must be"):
        lqr_gain(system, np.eye(3), np.eye(1))


@pytest.mark.parametrize("fidelity", ["ideal", "realistic"])
def test_swing_up_from_rest_and_stay_up(fidelity):
    env = pendkit.make(action_mode="continuous", fidelity=fidelity, start="rest", filter_coefficient=0.0)
    controller = SwingUpController.for_env(env)
    trace = run_episode(env, controller, seed=0)
    upright_at = time_to_upright_s(trace.pendulum_from_upright_rad, env.unwrapped.dt)
    assert upright_at is not None and upright_at < 10.0
    assert controller.mode == "balance"


def test_swing_up_with_the_env_filter_on():
    env = pendkit.make(action_mode="continuous", fidelity="ideal", start="rest")
    trace = run_episode(env, SwingUpController.for_env(env), seed=1)
    assert time_to_upright_s(trace.pendulum_from_upright_rad, env.unwrapped.dt) is not None


def test_energy_is_minus_one_hanging_and_one_upright():
    env = pendkit.make(start="rest")
    _, info = env.reset(seed=0)
    w0 = env.unwrapped.params.pendulum_natural_frequency_rad_s
    state = info["state"]
    assert pendulum_energy(state.pendulum_angle_rad, state.pendulum_velocity_rad_s, w0) == pytest.approx(-1.0)
    assert pendulum_energy(math.pi, 0.0, w0) == pytest.approx(1.0)


@pytest.mark.parametrize("kwargs, words", [
    ({"catch_angle_rad": 1.0, "fall_angle_rad": 0.5}, "must be below fall_angle_rad"),
    ({"energy_gain": -1.0}, "energy_gain"),
    ({"arm_limit_rad": 2.0}, "arm_limit_rad"),
])
def test_bad_swing_up_settings(kwargs, words):
    with pytest.raises(ConfigError, match=words):
        SwingUpConfig(**kwargs)
