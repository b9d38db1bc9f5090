"""The env keeps its promises: the episode limit asked for, observations inside observation_space,
pickling, and clear errors for arguments that make no sense."""

import pickle

import gymnasium as gym
import numpy as np
import pytest

import pendkit
from pendkit.network import LatencyModel, NetworkImpairment
from pendkit.sim.fidelity import Fidelity


def episode_length(env) -> int:
    env.reset(seed=0)
    steps = 0
    while True:
        *_, terminated, truncated, _ = env.step(0)
        steps += 1
        if terminated or truncated:
            return steps


@pytest.mark.parametrize("limit", [7, 600])  # shorter and longer than the default 500
def test_the_episode_limit_asked_for_is_the_one_kept(limit):
    assert episode_length(pendkit.make(max_episode_steps=limit)) == limit


def test_the_registered_spec_carries_the_limit_so_time_aware_wrappers_work():
    env = pendkit.make()
    assert env.spec.max_episode_steps == 500 and episode_length(env) == 500
    wrapped = gym.wrappers.TimeAwareObservation(pendkit.make())
    assert wrapped.observation_space.shape == (8,)


@pytest.mark.parametrize("fidelity", ["ideal", "paper-delayed"])
def test_observations_stay_inside_the_space_and_say_when_clipped(fidelity):
    env = pendkit.make(fidelity=fidelity)
    env.reset(seed=1)
    clipped = 0
    for k in range(300):  # pushed hard right: the arm overshoots the servo's end stop
        observation, *_, info = env.step(4 if k % 60 < 40 else 1)
        assert env.observation_space.contains(observation)
        clipped += info["observation_clipped"]
        if info["observation_clipped"]:
            assert abs(info["state"].arm_angle_rad) > np.pi / 2  # the raw reading is still in the info
    assert clipped > 0


@pytest.mark.parametrize("fidelity", ["ideal", "realistic"])
def test_the_env_pickles_and_the_copy_continues_identically(fidelity):
    env = pendkit.make(fidelity=fidelity)
    env.reset(seed=3)
    env.step(2)
    copy = pickle.loads(pickle.dumps(env))
    for action in (4, 0, 1):
        np.testing.assert_array_equal(env.step(action)[0], copy.step(action)[0])


@pytest.mark.parametrize("kwargs, says", [
    (dict(params={}), "RigParams"),
    (dict(max_episode_steps=0), "max_episode_steps"),
    (dict(max_episode_steps=2.5), "max_episode_steps"),
    (dict(rig_options={"settle": True}), "backend='rig'"),
    (dict(backend="rig", rig_options={"setle": True}), "unknown rig_options"),
    (dict(backend="rig", rig="r01/#"), "rig id"),
    (dict(log_dir=123), "log_dir"),
    (dict(filter_coefficient="0.5"), "filter_coefficient"),
    (dict(fidelity=Fidelity("x", network=NetworkImpairment(LatencyModel()))), None),  # valid: no error
])
def test_make_names_the_bad_argument(kwargs, says):
    if says is None:
        pendkit.make(**kwargs).reset(seed=0)
        return
    with pytest.raises(pendkit.ConfigError, match=says):
        pendkit.make(**kwargs)


@pytest.mark.parametrize("build, says", [
    (lambda: Fidelity("x", substeps_per_step=2.5), "substeps_per_step"),
    (lambda: Fidelity("x", substeps_per_step=True), "substeps_per_step"),
    (lambda: LatencyModel(floor_ms=1e9), "floor_ms"),   # would make reset wait forever
    (lambda: LatencyModel(samples_ms=(5.0, 1e7)), "samples_ms"),
    (lambda: pendkit.RigParams(encoder_offset_counts=5000), "encoder_offset_counts"),
    (lambda: pendkit.RigParams(encoder_offset_counts=-1), "encoder_offset_counts"),
])
def test_settings_outside_their_range_are_refused(build, says):
    with pytest.raises(pendkit.ConfigError, match=says):
        build()


def test_the_env_works_again_after_a_refused_reset():
    env = pendkit.make(fidelity="ideal")
    with pytest.raises(pendkit.ConfigError, match="start must be one of"):
        env.reset(options={"start": "sideways"})
    env.reset(seed=1)
    _, reward, *_ = env.step(0)
    assert np.isfinite(reward)


@pytest.mark.parametrize("options, says", [
    ({"pendulum_velocity_rad_s": 1e9}, "within \\+-40"), ({"pendulum_angle_rad": True}, "a finite number"),
    ({"arm_angle_rad": float("nan")}, "a finite number"),
])
def test_a_start_outside_physical_ranges_is_refused_and_changes_nothing(options, says):
    env = pendkit.make(fidelity="ideal")
    env.reset(seed=0)
    before = env.unwrapped.backend.true_state()
    with pytest.raises(pendkit.ConfigError, match=says):
        env.reset(options=options)
    assert env.unwrapped.backend.true_state() == before


def test_the_twin_refuses_a_broker():
    with pytest.raises(pendkit.ConfigError, match="for backend='rig'"):
        pendkit.make(fidelity="ideal", broker="mqtt://127.0.0.1:1883")


@pytest.mark.parametrize("url", ["mqtt://127.0.0.1:99999", "mqtt://[::1", "mqtt://:1883", "http://host", "mqtt://h:0"])
def test_a_malformed_broker_url_is_one_line_from_every_command(url):
    from click.testing import CliRunner

    from pendkit.cli import main

    for args in (["eval", "--policy", "dqn-ideal", "--backend", "rig"], ["deploy", "--rig", "r01", "--controller",
                                                                        "energy"], ["virtual-rig"]):
        result = CliRunner().invoke(main, [*args, "--broker", url])
        assert result.exit_code != 0, (args, result.output)
        assert "broker must look like mqtt://host:1883" in result.output, (args, result.output)
        assert "Traceback" not in result.output
