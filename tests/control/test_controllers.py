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
    ({"pendulum_angle": -1.0}, "LqrWeights.pendulum_angle must be finite and >= 0"),
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


def lab05_functions():
    """Lab 05's three answers, written as a student would (plain floats and strings)."""
    def energy(angle_from_bottom_rad, velocity_rad_s, natural_frequency_rad_s):
        return 0.5 * (velocity_rad_s / natural_frequency_rad_s) ** 2 - math.cos(angle_from_bottom_rad)

    def direction(angle_from_bottom_rad, velocity_rad_s):
        return -1 if velocity_rad_s * math.cos(angle_from_bottom_rad) > 0 else 1

    def next_mode(mode, angle_from_upright_rad, velocity_rad_s):
        if mode == "swing" and abs(angle_from_upright_rad) < 0.8 and abs(velocity_rad_s) < 5.0:
            return "balance"
        if mode == "balance" and abs(angle_from_upright_rad) > 1.1:
            return "swing"
        return mode

    return energy, direction, next_mode


def swing_up_trace(parts, seed=0, steps=200):
    env = pendkit.make(action_mode="continuous", fidelity="realistic", filter_coefficient=0.0)
    trace = run_episode(env, SwingUpController.for_env(env, parts=parts), seed=seed, steps=steps)
    return trace, env.unwrapped.dt


def test_a_students_swing_up_parts_drive_the_same_swing_as_the_kits():
    from pendkit.control.swingup import SwingUpParts

    energy, direction, next_mode = lab05_functions()
    theirs, dt = swing_up_trace(SwingUpParts(energy, direction, next_mode))
    ours, _ = swing_up_trace(None)
    np.testing.assert_allclose(theirs.pendulum_from_upright_rad, ours.pendulum_from_upright_rad)
    assert time_to_upright_s(theirs.pendulum_from_upright_rad, dt) is not None


@pytest.mark.parametrize("mistake", ["direction brakes", "never hands over"])
def test_a_wrong_swing_up_part_changes_what_the_student_sees(mistake):
    from pendkit.control.swingup import SwingUpParts

    energy, direction, next_mode = lab05_functions()
    if mistake == "direction brakes":
        parts = SwingUpParts(energy, lambda a, w: -direction(a, w), next_mode)
    else:
        parts = SwingUpParts(energy, direction, lambda mode, theta, w: "swing")
    trace, dt = swing_up_trace(parts, steps=300)
    right, _ = swing_up_trace(SwingUpParts(energy, direction, next_mode), steps=300)
    late_error = np.abs(trace.pendulum_from_upright_rad[-60:])
    assert late_error.max() > 0.3 or time_to_upright_s(trace.pendulum_from_upright_rad, dt) is None
    assert np.abs(right.pendulum_from_upright_rad[-60:]).max() < 0.1


@pytest.mark.parametrize("part, value, words", [
    ("direction", 0, "must be \\+1 or -1"), ("direction", "left", "must be a number"),
    ("energy", float("nan"), "finite"), ("next_mode", "catch", "'swing' or 'balance'"),
])
def test_a_malformed_swing_up_answer_is_refused(part, value, words):
    from pendkit.control.swingup import SwingUpParts

    parts = SwingUpParts(**{part: lambda *args: value})
    with pytest.raises(ConfigError, match=words):
        swing_up_trace(parts, steps=5)
