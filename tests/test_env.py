"""The one env: conformance, determinism, action mapping, bad input, rendering."""

import math
import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import pendkit
from pendkit.errors import ActionError, ConfigError

MODES = ("discrete", "continuous")
FIDELITIES = ("ideal", "paper-delayed", "realistic")


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("fidelity", FIDELITIES)
def test_check_env_on_every_variant(mode, fidelity):
    env = gymnasium.make(pendkit.ENV_ID, action_mode=mode, fidelity=fidelity)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a machine without GL draws frames instead
        check_env(env.unwrapped)


def test_registered_and_shortcut_agree():
    assert pendkit.ENV_ID in gymnasium.registry
    assert isinstance(pendkit.make().unwrapped, pendkit.SwingUpEnv)


def rollout(env, seed, steps=60):
    rng = np.random.default_rng(seed)
    observation, _ = env.reset(seed=seed)
    trace = [observation]
    for _ in range(steps):
        if env.unwrapped.action_mode == "discrete":
            action = int(rng.integers(5))
        else:
            action = rng.uniform(-1, 1, 1).astype(np.float32)
        trace.append(env.step(action)[0])
    return np.array(trace)


@pytest.mark.parametrize("fidelity", FIDELITIES)
@pytest.mark.parametrize("mode", MODES)
def test_same_seed_same_trajectory(fidelity, mode):
    a = rollout(pendkit.make(fidelity=fidelity, action_mode=mode), seed=5)
    b = rollout(pendkit.make(fidelity=fidelity, action_mode=mode), seed=5)
    c = rollout(pendkit.make(fidelity=fidelity, action_mode=mode), seed=6)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


def test_reset_reseeds_the_same_env():
    env = pendkit.make(fidelity="realistic")
    np.testing.assert_array_equal(rollout(env, 3), rollout(env, 3))


def test_truncates_after_500_steps_and_never_terminates():
    env = pendkit.make()
    env.reset(seed=0)
    for step in range(1, 501):
        _, _, terminated, truncated, _ = env.step(0)
        assert not terminated
        assert truncated == (step == 500)


def test_rest_start_hangs_still_and_earns_minus_pi_squared():
    env = pendkit.make(start="rest")
    observation, info = env.reset(seed=0)
    assert observation[0] == pytest.approx(-math.pi)
    _, reward, *_ = env.step(0)
    assert reward == pytest.approx(-math.pi**2, abs=1e-6)


def test_upright_start_earns_close_to_zero():
    env = pendkit.make(start="upright")
    env.reset(seed=0)
    _, reward, *_ = env.step(0)
    assert -0.05 < reward <= 0


def test_random_start_follows_the_authors_ranges():
    env = pendkit.make(observation=("pendulum_angle", "pendulum_velocity", "arm_angle"))
    angles = []
    for seed in range(40):
        observation, info = env.reset(seed=seed)
        angles.append(info["true_state"]["pendulum_angle_rad"])
        assert abs(info["true_state"]["pendulum_velocity_rad_s"]) <= 2.01
        assert abs(observation[2]) <= math.pi / 4 + 1e-6
    assert max(np.abs(angles)) <= 3.01 and np.std(angles) > 1.0


def test_observation_features_are_configurable():
    env = pendkit.make(observation=("pendulum_cos", "pendulum_sin", "servo_target"))
    observation, _ = env.reset(seed=0)
    assert observation.shape == (3,)
    assert observation[0] ** 2 + observation[1] ** 2 == pytest.approx(1.0, abs=1e-6)
    with pytest.raises(ConfigError, match="unknown observation features \\['angle'\\]"):
        pendkit.make(observation=("angle",))


def test_discrete_actions_move_the_arm_the_right_way():
    env = pendkit.make(start="rest", observation=("arm_angle",))
    env.reset(seed=0)
    for _ in range(5):
        observation, *_ = env.step(4)  # right fast: +4 counts per 10 ms
    assert observation[0] > 0.2
    for _ in range(10):
        observation, *_ = env.step(2)  # left fast
    assert observation[0] < -0.2


def test_continuous_actions_are_filtered():
    env = pendkit.make(action_mode="continuous", start="rest")
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.array([1.0], dtype=np.float32))
    # a_1 = 0.85 * 0 + 0.15 * 1: the target moves 15 % of the way
    assert info["servo_target_rad"] == pytest.approx(0.15 * math.pi / 2, rel=1e-6)
    _, _, _, _, info = env.step(np.array([1.0], dtype=np.float32))
    assert info["servo_target_rad"] == pytest.approx((0.85 * 0.15 + 0.15) * math.pi / 2, rel=1e-6)


def snapshot(env):
    base = env.unwrapped
    return (base.backend.data.qpos.copy(), base.backend.data.qvel.copy(), base.backend.data.act.copy(),
            base.backend.data.time, base._filtered_unit, base._steps, base.np_random.bit_generator.state)


def assert_same(a, b):
    for x, y in zip(a, b):
        if isinstance(x, np.ndarray):
            np.testing.assert_array_equal(x, y)
        else:
            assert x == y


@pytest.mark.parametrize("action, words", [
    (5, ["out of range", "0..4", "got 5"]),
    (-1, ["out of range", "got -1"]),
    (1.5, ["integer", "float"]),
    (True, ["boolean"]),
    (np.array([1, 2]), ["integer", "shape (2,)"]),
    ("left", ["integer", "str"]),
])
def test_bad_discrete_actions_raise_and_change_nothing(action, words):
    env = pendkit.make(fidelity="realistic")
    env.reset(seed=0)
    env.step(1)
    before = snapshot(env)
    with pytest.raises(ActionError) as error:
        env.step(action)
    assert isinstance(error.value, ValueError)
    for word in words:
        assert word in str(error.value)
    assert_same(before, snapshot(env))


@pytest.mark.parametrize("action, words", [
    (np.array([0.1, 0.2], dtype=np.float32), ["Action shape mismatch: expected (1,), got (2,)"]),
    (np.array([[0.1]], dtype=np.float32), ["expected (1,), got (1, 1)"]),
    (np.array([np.nan], dtype=np.float32), ["finite", "nan"]),
    (np.array([np.inf]), ["finite", "inf"]),
    (np.array([1.5]), ["out of range", "[-1, 1]", "1.5"]),
    (np.array(["a"]), ["numeric", "dtype"]),
    (None, ["numeric", "object"]),
])
def test_bad_continuous_actions_raise_and_change_nothing(action, words):
    env = pendkit.make(action_mode="continuous")
    env.reset(seed=0)
    env.step(np.array([0.5], dtype=np.float32))
    before = snapshot(env)
    with pytest.raises(ActionError) as error:
        env.step(action)
    for word in words:
        assert word in str(error.value)
    assert_same(before, snapshot(env))


def test_scalar_and_numpy_integer_actions_are_accepted():
    env = pendkit.make()
    env.reset(seed=0)
    env.step(np.int64(3))
    env.step(np.array(2))
    continuous = pendkit.make(action_mode="continuous")
    continuous.reset(seed=0)
    continuous.step(0.3)
    continuous.step(np.float32(1.0000001))  # float32 rounding at the bound is tolerated


@pytest.mark.parametrize("kwargs, words", [
    ({"fidelity": "perfect"}, ["unknown fidelity 'perfect'", "ideal", "realistic"]),
    ({"action_mode": "torque"}, ["action_mode", "'torque'"]),
    ({"start": "top"}, ["start", "'top'"]),
    ({"filter_coefficient": 1.0}, ["filter_coefficient", "[0, 1)"]),
    ({"backend": "robot"}, ["backend must be 'sim' or 'rig'", "'robot'"]),
    ({"render_mode": "human"}, ["render_mode", "'human'"]),
])
def test_bad_configuration_is_reported(kwargs, words):
    with pytest.raises(ConfigError) as error:
        pendkit.SwingUpEnv(**kwargs)
    for word in words:
        assert word in str(error.value)


def test_step_before_reset_is_an_error():
    with pytest.raises(gymnasium.error.ResetNeeded):
        pendkit.SwingUpEnv().step(0)


def test_timing_features_per_fidelity():
    ideal = pendkit.make(fidelity="ideal")
    ideal.reset(seed=0)
    _, _, _, _, info = ideal.step(0)
    assert info["time_since_action_s"] == pytest.approx(0.060) and info["observation_age_s"] == 0
    delayed = pendkit.make(fidelity="paper-delayed")
    delayed.reset(seed=0)
    ages = {round(delayed.step(0)[4]["observation_age_s"], 4) for _ in range(60)}
    assert ages == {0.0, 0.005, 0.01}
    realistic = pendkit.make(fidelity="realistic")
    realistic.reset(seed=0)
    ages = [realistic.step(0)[4]["observation_age_s"] for _ in range(200)]
    assert 0 <= min(ages) and max(ages) < 0.1 and np.std(ages) > 0.001


def test_realistic_observes_the_servo_command_not_the_arm():
    env = pendkit.make(fidelity="realistic", start="rest", observation=("arm_angle",))
    env.reset(seed=0)
    observation, _, _, _, info = env.step(4)
    counts = observation[0] / env.unwrapped.params.servo_rad_per_count
    assert counts == pytest.approx(round(counts), abs=1e-3)  # whole PCA9685 counts
    assert observation[0] != pytest.approx(info["true_state"]["arm_angle_rad"], abs=1e-4)


def test_realistic_overspin_stop_holds_the_servo():
    env = pendkit.make(fidelity="realistic", start="rest")
    env.reset(seed=0)
    backend = env.unwrapped.backend
    backend.data.qvel[backend._pend_v] = 4.0 * 2 * math.pi  # spinning at 4 rev/s at the bottom
    for _ in range(5):
        _, _, _, _, info = env.step(4)
        if "overspin" in info["safety_flags"]:
            break
    assert "overspin" in info["safety_flags"]
    held = backend._device.mcu.servo_counts
    while "overspin" in info["safety_flags"]:
        _, _, _, _, info = env.step(4)  # "right fast" is not obeyed while over-spinning
        if "overspin" in backend._device.mcu.flags:
            assert backend._device.mcu.servo_counts == held


@pytest.mark.parametrize("fidelity", FIDELITIES)
def test_render_rgb_array(fidelity):
    env = pendkit.make(render_mode="rgb_array", fidelity=fidelity)
    env.reset(seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        frame = env.render()
    assert frame.ndim == 3 and frame.shape[2] == 3 and frame.dtype == np.uint8 and frame.std() > 5
    env.close()


def test_drawn_frames_follow_the_pendulum():
    from pendkit.sim.render import DrawnFrames

    frames = DrawnFrames(pendkit.RigParams())
    hanging = frames.frame(0.0, 0.0)
    upright = frames.frame(0.0, math.pi)
    assert hanging.shape == upright.shape == (360, 480, 3)
    assert np.abs(hanging.astype(int) - upright.astype(int)).sum() > 1000


def test_rendering_without_gl_falls_back_to_drawing(monkeypatch):
    import pendkit.sim.render as render

    monkeypatch.setattr(render, "_GL_FAILED", True)  # as on a machine with no OpenGL at all
    env = pendkit.make(render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (360, 480, 3)


def test_the_rendered_twin_is_lit_and_hangs_down_at_rest():
    """What lab 00's "look at the rig" cell shows: a readable picture with the dowel hanging vertically."""
    env = pendkit.make(render_mode="rgb_array", start="rest")
    env.reset(seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        frame = env.render().astype(int)
    env.close()
    assert frame.mean() > 80 and (frame.max(axis=2) < 30).mean() < 0.2
    red, green, blue = frame[..., 0], frame[..., 1], frame[..., 2]
    rows, columns = np.nonzero((red - blue > 50) & (red > green) & (green > blue))  # the pine dowel
    assert len(rows) > 100
    assert np.ptp(rows) > 4 * np.ptp(columns)
