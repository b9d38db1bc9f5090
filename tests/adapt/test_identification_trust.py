"""An identification `pendkit adapt` does not deploy from (issue 72, part 5): recordings that pass every check
but that no twin can follow (an encoder counting the other way) end in a fit hardly better than a pendulum
that never moved; adapt then writes its report and figure, nothing deployable, unless told otherwise."""

import dataclasses
import json

import numpy as np
import pytest

from pendkit.adapt import recording_checks, session
from pendkit.adapt.identification_trust import distrust, motionless_cost
from pendkit.adapt.identify import Identification, identify, matching_cost
from pendkit.adapt.recording_checks import check_recordings
from pendkit.adapt.replay import replay_cost
from pendkit.adapt.rigs import twin_rig
from pendkit.errors import IdentificationError
from tests.adapt.test_recording_checks import HIDDEN, recorded

DEPLOYABLE = ("rig.json", "policy.pt", "device-controller.pkcb", "device-policy.pkcb", "device-design-rig.json")


def reversed_encoder(recording):
    """The same swings read by an encoder counting the other way (its CW/CCW pin): every check still passes."""
    trace = recording.device
    first = trace.pendulum_rad[0]
    start = recording.start_pendulum_rad
    return dataclasses.replace(
        recording, pendulum_rad=[float((2 * start - a) % (2 * np.pi)) for a in recording.pendulum_rad],
        pendulum_velocity_rad_s=[-w for w in recording.pendulum_velocity_rad_s],
        device=dataclasses.replace(trace, pendulum_rad=tuple(2 * first - a for a in trace.pendulum_rad)))


@pytest.fixture(scope="module")
def healthy(tmp_path_factory):
    return recorded(HIDDEN, "classroom-wifi", tmp_path_factory.mktemp("logs"))


def test_a_fit_that_follows_the_swings_is_trusted_one_of_a_reversed_encoder_is_not(healthy):
    own = Identification(HIDDEN, 10.0, replay_cost(HIDDEN, 0.0, healthy), 1.0, 0, 0.0, pwm_phase_ms=0.0)
    assert distrust(own, healthy) is None
    assert own.cost < 0.01 * motionless_cost(healthy, device_clock=True)  # far inside the limit
    flipped = [reversed_encoder(r) for r in healthy]
    check_recordings(flipped, HIDDEN)  # nothing a check can see
    fit = identify(flipped, HIDDEN, max_evaluations=30)
    said = distrust(fit, flipped)
    assert said.startswith("the identified twin matches the recordings hardly better than a pendulum that never "
                           "moved (matching cost") and "CW/CCW pin" in said


def test_on_the_hosts_steps_too_and_a_cost_that_is_not_a_number_is_never_trusted(healthy):
    host_only = [dataclasses.replace(r, device=None) for r in healthy]
    own = Identification(HIDDEN, 10.0, matching_cost(HIDDEN, 10.0, host_only), 1.0, 0, 0.0)
    assert distrust(own, host_only) is None
    flipped = [dataclasses.replace(reversed_encoder(r), device=None) for r in healthy]
    assert "hardly better" in distrust(dataclasses.replace(own, cost=matching_cost(HIDDEN, 10.0, flipped)), flipped)
    assert "matching cost is nan (prior) -> 4" in distrust(dataclasses.replace(own, cost=4.0, prior_cost=np.nan),
                                                           host_only)


def untrusted_session(tmp_path, monkeypatch, **config):
    real_record = recording_checks.record
    monkeypatch.setattr(recording_checks, "record", lambda env, excitation, seed: reversed_encoder(
        real_record(env, excitation, seed)))
    settings = dict(episodes=2, excitation_episodes=2, twin_episodes=1, evaluation_episodes=1, candidates=(),
                    policy="r-dqn-realistic", identification_evaluations=30, identification_restarts=1)
    return session.adapt(twin_rig(HIDDEN, "none"), tmp_path, session.AdaptConfig(**{**settings, **config}),
                         say=lambda text: None)


def test_adapt_writes_its_report_and_nothing_deployable_from_an_identification_it_does_not_trust(
        tmp_path, monkeypatch):
    with pytest.raises(IdentificationError, match=r"identification not trusted: the identified twin matches the "
                                                  r"recordings hardly better .* Nothing deployed .*--deploy-untrusted"):
        untrusted_session(tmp_path, monkeypatch)
    assert not [name for name in DEPLOYABLE if (tmp_path / name).exists()]
    assert (tmp_path / "excitation.json").exists() and len(list((tmp_path / "excitation-logs").iterdir())) >= 2
    assert (tmp_path / "identification.png").read_bytes()[:4] == b"\x89PNG"
    assert "hardly better" in json.loads((tmp_path / "report.json").read_text())["untrusted"]
    text = (tmp_path / "report.md").read_text()
    assert text.startswith("# Adaptation of twin (none): not deployed") and "Nothing deployable was written" in text


@pytest.mark.expensive  # a whole session, deployed: about 25 s
def test_told_to_adapt_deploys_from_it_all_the_same_and_the_report_says_so(tmp_path, monkeypatch):
    report = untrusted_session(tmp_path, monkeypatch, deploy_untrusted=True)
    assert (tmp_path / "rig.json").exists() and (tmp_path / "policy.pt").exists()
    assert "hardly better" in report["untrusted"]
    assert "**Deployed from an identification not trusted**" in (tmp_path / "report.md").read_text()
