"""Domain randomisation: every episode a new rig (servo, masses, pendulum, pulses, calibration, network)
within the documented ranges; held-out rigs from ranges 20% wider."""

import numpy as np
import pytest
from click.testing import CliRunner

import pendkit
from pendkit.errors import ConfigError
from pendkit.network import PERFECT_NETWORK
from pendkit.rig import SERVO_PRESETS, RigParams
from pendkit.sim.fidelity import FIDELITY_PRESETS
from pendkit.sim.randomize import (
    MASS_FIELDS,
    SERVO_FIELDS,
    TRAINING_RANGES,
    DomainRandomization,
    held_out_rigs,
    parse_randomize,
    sample_rig,
)


def test_samples_stay_within_the_presets_and_mass_spread():
    rng = np.random.default_rng(0)
    base = RigParams()
    presets = [RigParams.preset(name) for name in SERVO_PRESETS]
    for _ in range(50):
        rig = sample_rig(base, ("servo", "masses"), rng).params
        for field in SERVO_FIELDS:
            values = [getattr(p, field) for p in presets]
            assert min(values) <= getattr(rig, field) <= max(values)
        for field in MASS_FIELDS:
            low, high = TRAINING_RANGES.tip_mass_scale if field == "tip_mass_kg" else TRAINING_RANGES.mass_scale
            assert low * getattr(base, field) <= getattr(rig, field) <= high * getattr(base, field)
        assert (rig.servo_min_counts, rig.servo_max_counts) in {(p.servo_min_counts, p.servo_max_counts)
                                                                for p in presets}
    assert sample_rig(base, (), rng).params == base


def test_robust_training_covers_the_pendulum_pulses_calibration_and_network():
    rng = np.random.default_rng(3)
    base = RigParams()
    rigs = [sample_rig(base, parse_randomize("robust"), rng) for _ in range(200)]
    damping = [r.params.pendulum_damping_n_m_s_per_rad / base.pendulum_damping_n_m_s_per_rad for r in rigs]
    assert min(damping) < 0.7 and max(damping) > 2.5  # up to (at least) 2.5x the default bearing
    lengths = [r.params.dowel_length_m for r in rigs]
    assert min(lengths) < 0.32 and max(lengths) > 0.43
    for r in rigs:  # the dowel's mass follows its length; the network and calibration come with the rig
        per_metre = (r.params.dowel_mass_kg / r.params.dowel_length_m) / (base.dowel_mass_kg / base.dowel_length_m)
        assert TRAINING_RANGES.mass_scale[0] <= per_metre <= TRAINING_RANGES.mass_scale[1]
        assert 150 <= r.params.servo_min_counts <= 200 and 400 <= r.params.servo_max_counts <= 450
        assert abs(r.residual_offset_counts) <= 6 and 0 <= r.network.observation_loss_pct <= 3
    assert len({r.residual_offset_counts for r in rigs}) > 5  # calibration errors of many sizes
    assert max(r.network.latency.median_ms for r in rigs) > 12  # drawn latency parameters reach poor WiFi's


def test_held_out_rigs_come_from_wider_ranges_and_are_reproducible():
    rigs, again = held_out_rigs(10, seed=7), held_out_rigs(10, seed=7)
    assert [r.params for r in rigs] == [r.params for r in again]
    wide = TRAINING_RANGES.widened(1.2)
    low, high = TRAINING_RANGES.servo_speed_s_per_60deg
    assert wide.servo_speed_s_per_60deg == pytest.approx((low - 0.1 * (high - low), high + 0.1 * (high - low)))
    assert wide.loss_pct[0] == 0.0 and wide.latency_floor_ms[0] == 0.0  # nothing below physical zero
    many = held_out_rigs(300, seed=1)
    speeds = [r.params.servo_speed_s_per_60deg for r in many]
    assert min(speeds) < low and max(speeds) > high  # some lie outside what training saw


def test_a_residual_calibration_error_shifts_the_hanging_reading():
    readings = {}
    for residual in (0, 5):
        fidelity = FIDELITY_PRESETS["realistic"].replace(encoder_residual_offset_counts=residual,
                                                         network=PERFECT_NETWORK)
        env = pendkit.make(fidelity=fidelity, start="rest")
        env.reset(seed=0)
        readings[residual] = env.unwrapped._state.encoder_counts
    assert (readings[5] - readings[0]) % 1024 == 5


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


def test_an_estimating_env_keeps_its_observer_for_the_base_rig_through_every_drawn_one():
    """Trained over rigs, the observer must not know the rig it is on (on a real rig the laptop does not)."""
    env = DomainRandomization(pendkit.make(fidelity="realistic", action_mode="continuous", features="estimated"),
                              "robust", seed=3)
    for episode in range(3):
        env.reset(seed=episode)
        env.step(np.array([0.5], dtype=np.float32))
        base = env.unwrapped
        assert base.params != RigParams() and base._estimator.params == RigParams()
    told = DomainRandomization(pendkit.make(fidelity="realistic", action_mode="continuous", features="estimated"),
                               "robust", seed=3, observer_follows_rig=True)
    told.reset(seed=0)
    assert told.unwrapped._estimator.params == told.unwrapped.params != RigParams()  # told each drawn rig
    # unpinned, the observer follows the twin (an env made for one known rig)
    direct = pendkit.make(fidelity="realistic", action_mode="continuous", features="estimated")
    direct.unwrapped.set_rig(RigParams.preset("mks-x5-hbl550"))
    assert direct.unwrapped._estimator.params == RigParams.preset("mks-x5-hbl550")
    with pytest.raises(ConfigError, match="observer_params"):
        pendkit.make(observer_params=RigParams())  # measured features have no observer


def test_a_pinned_observer_keeps_the_base_delays_unless_told_to_follow_each_drawn_rigs():
    """Pinned, the observer keeps the base twin's delays on every drawn network; `keep_timing=False` keeps its
    rig but designs for each drawn rig's own delays (what a rig's evaluation and the device do)."""
    env = DomainRandomization(pendkit.make(fidelity="realistic", action_mode="continuous", features="estimated"),
                              "robust", seed=3)
    base = env.unwrapped
    base_delay_s = base.timing.command_delay_s
    designed, drawn = [], []
    for keep in (True, False):
        base.pin_observer(keep_timing=keep)  # the rig it was pinned to by DomainRandomization: the base one
        for episode in range(3):
            env.reset(seed=episode)
            observer = base._estimator.observer
            designed.append(observer.actuation_delay_s)
            drawn.append(base.timing.command_delay_s)
            assert base._estimator.params == RigParams()
    assert designed[:3] == [base_delay_s] * 3 and len(set(drawn[:3])) == 3
    assert designed[3:] == drawn[3:] and len(set(drawn[3:])) == 3


def test_bad_requests_are_refused_with_the_choices():
    with pytest.raises(ConfigError, match="servo, latency, masses, pendulum"):
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
    assert result.exit_code != 0 and "servo, latency, masses" in result.output and "robust" in result.output


def test_a_preset_added_to_the_kit_leaves_the_drawn_rigs_as_they_were(monkeypatch):
    before = [rig.params for rig in held_out_rigs(8, seed=5)]
    extra = {**SERVO_PRESETS["hitec-d645mw"], "discrete_slow_step_counts": 3}
    monkeypatch.setitem(SERVO_PRESETS, "aaa-new-servo", extra)  # sorts first: it would shift a preset draw
    assert [rig.params for rig in held_out_rigs(8, seed=5)] == before


def test_the_ranges_follow_the_presets_and_the_worst_network():
    """A servo preset added to the kit widens the servo ranges it lies outside; the network ranges reach the
    worst impairment's figures (nothing copied by hand)."""
    from pendkit.network import IMPAIRMENTS, LatencyModel, NetworkImpairment
    from pendkit.rig import SERVO_PRESETS, RigParams
    from pendkit.sim.randomize import TRAINING_RANGES, network_ranges, preset_ranges

    speeds = [RigParams.preset(name).servo_speed_s_per_60deg for name in SERVO_PRESETS]
    assert TRAINING_RANGES.servo_speed_s_per_60deg == (min(speeds), max(speeds))
    slower = {**SERVO_PRESETS, "a-slow-servo": {"servo_speed_s_per_60deg": 0.4, "servo_damping_ratio": 1.1}}
    widened = preset_ranges(slower)
    assert widened["servo_speed_s_per_60deg"][1] == 0.4 and widened["servo_damping_ratio"][1] == 1.1
    assert widened["servo_stall_torque_kg_cm"] == TRAINING_RANGES.servo_stall_torque_kg_cm
    poor = IMPAIRMENTS["poor-wifi"]
    assert TRAINING_RANGES.latency_median_ms == (0.0, poor.latency.median_ms)
    assert TRAINING_RANGES.loss_pct == (0.0, max(poor.command_loss_pct, poor.observation_loss_pct))
    worse = network_ranges(NetworkImpairment(LatencyModel(floor_ms=9.0, median_ms=40.0, spread=1.0), 10.0, 5.0))
    assert worse["latency_floor_ms"] == (0.0, 9.0) and worse["loss_pct"] == (0.0, 10.0)
