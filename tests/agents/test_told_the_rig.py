"""The privileged ablation (benchmarks/bench_privileged.py) tells its learner the rig it is on: the numbers it
appends must follow the rig drawn at each reset, or the ablation would measure nothing."""

import importlib.util
from pathlib import Path

import numpy as np

from pendkit.agents.pretrained import POLICIES
from pendkit.agents.runs import make_env
from pendkit.sim.randomize import TRAINING_RANGES


def _bench():
    path = Path(__file__).resolve().parents[2] / "benchmarks" / "bench_privileged.py"
    spec = importlib.util.spec_from_file_location("bench_privileged", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_appended_rig_follows_each_newly_drawn_rig():
    bench = _bench()
    env = bench.ToldTheRig(make_env(POLICIES["r-dqn-robust"].run))
    told = []
    for seed in (1, 2):
        observation, _ = env.reset(seed=seed)
        assert observation.shape == env.observation_space.shape
        drawn = env.env.rig.params.servo_speed_s_per_60deg
        low, high = TRAINING_RANGES.servo_speed_s_per_60deg
        assert observation[-12] == np.float32((drawn - low) / (high - low))
        told.append(observation[-12:])
    env.close()
    assert not np.allclose(told[0], told[1])
    assert all(-0.01 <= value <= 1.01 for value in np.concatenate(told))
