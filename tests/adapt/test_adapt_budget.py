"""`pendkit adapt` within a class's patience: identification over the cores, an excitation as long as the fit
needs, and a laptop budget that cuts training, never the verdicts, and says what it cut."""

import functools
import time

import numpy as np
import pytest

from pendkit.adapt import excite_identify
from pendkit.adapt.cost_pool import CostPool
from pendkit.adapt.excitation import schedule
from pendkit.adapt.identify import candidate, identify_best, search_box
from pendkit.adapt.recording_checks import record_checked
from pendkit.adapt.replay import replay_cost
from pendkit.adapt.rigs import twin_rig
from pendkit.adapt.session import AdaptConfig, budget_cuts
from pendkit.errors import ConfigError
from pendkit.rig import RigParams

HIDDEN = RigParams.preset("hitec-hsb-9380th").with_dowel_length(0.38)


@pytest.fixture(scope="module")
def logged():
    recordings, prior, _ = record_checked(twin_rig(HIDDEN, "classroom-wifi"), schedule(2))
    return recordings, prior


def test_candidates_costed_over_two_processes_cost_what_they_cost_here(logged):
    recordings, prior = logged
    box = np.array(search_box((0.0, prior.pwm_period_ms)))
    xs = np.random.default_rng(1).uniform(box[:, 0], box[:, 1], size=(6, len(box)))
    xs[0] = [0.0] * (len(box) - 1) + [10.0]
    at = functools.partial(candidate, prior)
    with CostPool(replay_cost, at, recordings, workers=2) as pool:
        spread = pool.costs(xs)
    with CostPool(replay_cost, at, recordings, workers=1) as pool:
        here = pool.costs(xs)
    assert spread == here  # the same numbers, in the same order, whatever ran them
    assert len(set(here)) == len(here) and min(here) < 4.0  # distinct candidates, none refused


def test_identification_starts_no_search_that_would_end_after_its_deadline(logged):
    recordings, prior = logged
    unbounded = identify_best(recordings, prior, 40, seeds=(0, 1, 2))
    bounded = identify_best(recordings, prior, 40, seeds=(0, 1, 2), deadline=time.time())
    assert (unbounded.searches, bounded.searches) == (3, 1)
    assert bounded.evaluations < unbounded.evaluations


@pytest.mark.parametrize("spread, episodes", [(100.0, 2), (1.0, 3)])
def test_the_excitation_records_more_only_while_the_recordings_leave_the_servo_uncertain(monkeypatch, spread,
                                                                                        episodes):
    """With a loose bound the minimum's two episodes do; with an impossible one (no interval is narrower than the
    fit itself) it records up to the maximum, each episode counted as rig time."""
    monkeypatch.setattr(excite_identify, "EXCITATION_SPREAD", spread)
    rig = twin_rig(HIDDEN, "classroom-wifi")
    config = AdaptConfig(episodes=3, excitation_episodes=3, min_excitation_episodes=2, identification_evaluations=30,
                         identification_restarts=1)
    said = []
    found = excite_identify.excite_and_identify(rig, config, float("inf"), said.append, tolerance=1.0)
    assert len(found.jumps) == len(found.recordings) == episodes
    assert rig.seconds() == pytest.approx(sum(r.rig_steps for r in found.recordings) * 0.06)
    assert len(found.logs) >= episodes - 1  # every episode's device log kept
    assert set(found.widest) == set(excite_identify.PINNED) and all(w >= 1.0 for w in found.widest.values())
    assert (len(said) == 1) == (episodes == 3)  # the extra episode is announced with why
    if said:
        assert "servo_speed_s_per_60deg within" in said[0]


def test_a_spent_budget_keeps_every_verdict_trains_nothing_and_says_so(tmp_path):
    from pendkit.adapt.candidates import choose_on_twin
    from pendkit.adapt.identify import Identification

    fit = Identification(RigParams(), 10.0, 0.01, 0.1, 10, 1.0)
    config = AdaptConfig(policy="dqn-ideal", candidates=("td3-realistic",), twin_episodes=5)
    said = []
    run, rows, _ = choose_on_twin(fit, config, tmp_path / "policy.pt", said.append, deadline=time.time(), workers=1)
    assert [(row["policy"], row["stage"]) for row in rows] == [("dqn-ideal", "as shipped"),
                                                               ("td3-realistic", "as shipped")]
    assert all(row["episodes"] == 10 for row in rows)  # the verdicts are whole: the budget cut the training
    cuts = budget_cuts(config, {"candidates_on_twin": rows})
    assert cuts == ["dqn-ideal not trained on the twin", "td3-realistic not trained on the twin"]
    assert run.spec.learner == "td3+estimated"  # still the one that holds


def test_the_budget_must_be_a_positive_number_of_seconds_or_none():
    assert AdaptConfig(budget_s=None).budget_s is None
    for bad in (0.0, -5.0, float("nan")):
        with pytest.raises(ConfigError, match="budget_s"):
            AdaptConfig(budget_s=bad)
    with pytest.raises(ConfigError, match="min_excitation_episodes"):
        AdaptConfig(min_excitation_episodes=0)


def test_the_excitation_stops_when_another_episode_no_longer_narrows_the_servo(monkeypatch):
    """Nothing ever passes (a bound of x/÷1.0) and no episode can narrow enough (all of the excess): after the
    minimum's fit and one more episode's, it stops short of the maximum and says why."""
    monkeypatch.setattr(excite_identify, "EXCITATION_SPREAD", 1.0)
    monkeypatch.setattr(excite_identify, "NARROWING", 1.0)
    config = AdaptConfig(episodes=4, excitation_episodes=4, min_excitation_episodes=2, identification_evaluations=30,
                         identification_restarts=1)
    said = []
    found = excite_identify.excite_and_identify(twin_rig(HIDDEN, "classroom-wifi"), config, float("inf"),
                                                said.append, tolerance=1.0)
    assert len(found.jumps) == 3 and "hardly narrowed it: no more" in said[-1]
    assert found.identification.evaluations > 30  # the second fit's evaluations added to the first's
