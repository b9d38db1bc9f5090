"""Domain randomisation: every episode a new servo, network and masses, within the kit's own ranges."""

import numpy as np
import pytest
from click.testing import CliRunner

import pendkit
from pendkit.errors import ConfigError
from pendkit.rig import SERVO_PRESETS, RigParams
from pendkit.sim.randomize import (
    MASS_FIELDS,
    SERVO_FIELDS,
    DomainRandomization,
    parse_randomize,
    sample_rig,
)


def test_samples_stay_within_the_presets_and_mass_spread():
    rng = np.random.default_rng(0)
    base = RigParams()
    presets = [RigParams.preset(name) for name in SERVO_PRESETS]
    for _ in range(50):
        rig = sample_rig(base, ("servo", "masses"), rng)
        for field in SERVO_FIELDS:
            values = [getattr(p, field) for p in presets]
            assert min(values) <= getattr(rig, field) <= max(values)
        for field in MASS_FIELDS:
            assert 0.9 * getattr(base, field) <= getattr(rig, field) <= 1.1 * getattr(base, field)
        assert (rig.servo_min_counts, rig.servo_max_counts) in {(p.servo_min_counts, p.servo_max_counts)
                                                                for p in presets}
    assert sample_rig(base, (), rng) == base


def test_each_episode_runs_on_a_new_rig_and_the_physics_follows():
    env = DomainRandomization(pendkit.make(fidelity="realistic"), "servo,latency,masses", seed=1)
    seen = set()
    for episode in range(4):
        env.reset(seed=episode)
        for _ in range(5):
            env.step(4)
        base = env.unwrapped
        seen.add((base.params.servo_speed_s_per_60deg, base.backend.fidelity.latency.median_ms))
        assert base.backend.params is base.params  # the twin runs the drawn parameters
    assert len(seen) == 4


def test_bad_requests_are_refused_with_the_choices():
    with pytest.raises(ConfigError, match="servo, latency, masses"):
        parse_randomize("servo,wind")
    with pytest.raises(ConfigError, match="MCU pipeline"):
        DomainRandomization(pendkit.make(fidelity="ideal"), "latency")


def test_train_command_randomises_and_eval_runs_on_another_preset(tmp_path):
    pytest.importorskip("torch")
    from pendkit.cli import main

    out = tmp_path / "run"
    result = CliRunner().invoke(main, ["train", "--algo", "r-dqn", "--fidelity", "realistic", "--episodes", "2",
                                       "--max-steps", "30", "--randomize", "servo,masses", "--quiet",
                                       "--out", str(out)])
    assert result.exit_code == 0, result.output
    result = CliRunner().invoke(main, ["eval", str(out), "--episodes", "2", "--preset", "turnigy-tgy-wp23"])
    assert result.exit_code == 0 and "solved=0/2 median_upright_s=-" in result.output, result.output
    result = CliRunner().invoke(main, ["train", "--randomize", "wind", "--out", str(out)])
    assert result.exit_code != 0 and "servo, latency, masses" in result.output
