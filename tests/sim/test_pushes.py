"""Pushes on the twin: the named sizes change the pendulum's rate, at random moments, and a controller that
balances catches them."""

import numpy as np
import pytest

import pendkit
from pendkit.deploy.controllers import CONTROLLER_NAMES, controller_named
from pendkit.episode import run_episode
from pendkit.errors import ConfigError
from pendkit.features import holds_upright
from pendkit.sim.pushes import PUSH_SIZES_RAD_S, PUSH_WINDOW_STEPS, PendulumPushes


def test_a_push_changes_the_pendulum_rate_by_its_size_between_two_readings():
    pushed = PendulumPushes(pendkit.make(fidelity="ideal", action_mode="continuous"), "shove", per_episode=2)
    plain = pendkit.make(fidelity="ideal", action_mode="continuous")
    pushed.reset(seed=3, options={"start": "rest"})
    plain.reset(seed=3, options={"start": "rest"})
    pushes = []
    for _ in range(PUSH_WINDOW_STEPS[1]):
        _, _, _, _, info = pushed.step(np.zeros(1, np.float32))
        plain.step(np.zeros(1, np.float32))
        if info["push_rad_s"]:
            gap = (pushed.unwrapped.backend.true_state()["pendulum_velocity_rad_s"]
                   - plain.unwrapped.backend.true_state()["pendulum_velocity_rad_s"])
            pushes.append((info["push_rad_s"], gap))
            break  # the first push: the two twins were identical until it
    assert pushes and abs(pushes[0][0]) == PUSH_SIZES_RAD_S["shove"]
    assert pushes[0][1] == pytest.approx(pushes[0][0], abs=1e-9)


def test_the_same_seed_pushes_at_the_same_moments_and_another_seed_elsewhere():
    def moments(seed):
        env = PendulumPushes(pendkit.make(fidelity="ideal", max_episode_steps=PUSH_WINDOW_STEPS[1]), "hand", 2)
        env.reset(seed=seed)
        return [k for k in range(PUSH_WINDOW_STEPS[1]) if env.step(0)[4]["push_rad_s"]]

    first = moments(1)
    assert first == moments(1) and first != moments(2)
    assert all(PUSH_WINDOW_STEPS[0] <= k < PUSH_WINDOW_STEPS[1] for k in first)


@pytest.mark.parametrize("controller", CONTROLLER_NAMES)
def test_the_classical_controllers_catch_two_hand_pushes_on_the_realistic_twin(controller):
    env = PendulumPushes(pendkit.make(action_mode="continuous", fidelity="realistic", filter_coefficient=0.0), "hand")
    trace = run_episode(env, controller_named(controller).host(env), seed=10_001, options={"start": "rest"})
    assert holds_upright(trace.pendulum_from_upright_rad, 200)


def test_a_push_after_a_bad_action_is_not_applied():
    env = PendulumPushes(pendkit.make(fidelity="ideal", action_mode="continuous"), "hand", per_episode=10)
    env.reset(seed=0)
    env._schedule = {0: 1.0}
    rate = env.unwrapped.backend.true_state()["pendulum_velocity_rad_s"]
    with pytest.raises(pendkit.ActionError):
        env.step(np.array([np.nan], np.float32))
    assert env.unwrapped.backend.true_state()["pendulum_velocity_rad_s"] == rate


@pytest.mark.parametrize("size, count, message", [("kick", 2, "unknown push size"), ("hand", -1, "per_episode"),
                                                  ("hand", 2.5, "per_episode"), ("hand", 11, "per_episode")])
def test_bad_push_settings_are_named(size, count, message):
    with pytest.raises(ConfigError, match=message):
        PendulumPushes(pendkit.make(fidelity="ideal"), size, count)
