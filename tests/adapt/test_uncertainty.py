"""What the recordings leave uncertain: intervals about a fit that still match the recordings, wider for a
field the recordings hardly show than for one they pin, narrower when less mismatch is allowed; and the twin
`pendkit adapt` trains on drawing a new rig from them every episode while its observer keeps the fit."""

import dataclasses
import math

import pytest

import pendkit
from pendkit.adapt.excitation import Excitation, record, schedule
from pendkit.adapt.identify import Identification, matching_cost
from pendkit.adapt.rigs import twin_rig
from pendkit.adapt.uncertainty import RIG_FIELDS, AroundTheFit, fit_spread
from pendkit.rig import RigParams

HIDDEN = RigParams.preset("hitec-d645mw-4v8").with_dowel_length(0.36)


@pytest.fixture(scope="module")
def recordings():
    env = twin_rig(HIDDEN, "classroom-wifi").make_env(**Excitation.env_kwargs())  # a rig's jitter and losses
    recs = [record(env, excitation, seed=k) for k, excitation in enumerate(schedule(3))]
    env.close()
    return recs


def exact_fit(recordings) -> Identification:
    """The rig's own parameters at the latency that matches best (as an identification would find them)."""
    cost, latency_ms = min((matching_cost(HIDDEN, ms, recordings), ms) for ms in (0.0, 4.0, 8.0, 12.0, 16.0))
    return Identification(HIDDEN, latency_ms, cost, cost, 0, 0.0)


def log_width(interval) -> float:
    return math.log(interval[1] / interval[0])


def test_every_interval_holds_the_fit_and_its_ends_still_match_the_recordings(recordings):
    fit = exact_fit(recordings)
    spread = fit_spread(fit, recordings, tolerance=1.0)
    assert set(spread) == {*RIG_FIELDS, "latency_ms"}
    for name in RIG_FIELDS:
        low, high = spread[name]
        assert low < getattr(HIDDEN, name) < high, name
    low_ms, high_ms = spread["latency_ms"]
    assert low_ms <= fit.latency_ms <= high_ms
    ends = [dataclasses.replace(HIDDEN, servo_speed_s_per_60deg=value) for value in spread["servo_speed_s_per_60deg"]]
    assert all(matching_cost(params, fit.latency_ms, recordings) <= 2.0 * fit.cost for params in ends)
    # the servo's speed shows in every jump; its loop's stiffness hardly does
    assert log_width(spread["servo_speed_s_per_60deg"]) < log_width(spread["servo_full_torque_error_deg"])


def test_allowing_less_mismatch_narrows_what_the_recordings_allow(recordings):
    fit = exact_fit(recordings)
    loose, tight = fit_spread(fit, recordings, tolerance=1.0), fit_spread(fit, recordings, tolerance=0.1)
    for name in RIG_FIELDS:
        assert loose[name][0] <= tight[name][0] <= tight[name][1] <= loose[name][1], name
    assert sum(map(log_width, (tight[n] for n in RIG_FIELDS))) < sum(map(log_width, (loose[n] for n in RIG_FIELDS)))


def test_the_twin_draws_a_new_rig_from_the_intervals_each_episode_and_its_observer_keeps_the_fit():
    fit = Identification(HIDDEN, 5.0, 0.01, 0.1, 0, 0.0)
    spread = {"servo_speed_s_per_60deg": (0.2, 0.3), "dowel_length_m": (0.33, 0.39), "latency_ms": (3.0, 9.0)}
    env = AroundTheFit(pendkit.make(fidelity="realistic", params=HIDDEN, action_mode="continuous",
                                    features="estimated"), fit, spread, seed=3)
    drawn = []
    for episode in range(4):
        env.reset(seed=episode)
        params = env.unwrapped.params
        assert params == env.drawn and 0.2 <= params.servo_speed_s_per_60deg <= 0.3
        assert 0.33 <= params.dowel_length_m <= 0.39 and params.dowel_mass_kg < HIDDEN.dowel_mass_kg * 0.39 / 0.36
        assert params.servo_stall_torque_kg_cm == HIDDEN.servo_stall_torque_kg_cm  # not in the spread: the fit's
        assert 3.0 <= env.unwrapped.backend.fidelity.network.latency.floor_ms <= 9.0
        assert env.unwrapped._estimator.params == HIDDEN  # what the laptop knows, not the drawn rig
        env.step(env.action_space.sample())
        drawn.append(params.servo_speed_s_per_60deg)
    assert len(set(drawn)) == 4
    env.close()
