"""The whole `pendkit adapt` session on a hidden twin: rig, policy and report written, rig time counted by the
rig (its own file: the longest test of the adapt suite, spread across workers on its own)."""

import json

import pytest

from pendkit.adapt.excitation import REST_STEPS
from pendkit.adapt.rigs import twin_rig
from pendkit.rig import RigParams
from tests.adapt.test_adapt import HIDDEN


def test_an_adaptation_session_writes_rig_policy_and_report_within_its_rig_time(tmp_path):
    pytest.importorskip("torch")
    from pendkit.adapt.session import AdaptConfig, adapt
    from pendkit.adapt.trials import FINALISTS, trial_steps

    rig = twin_rig(HIDDEN, "none")
    config = AdaptConfig(episodes=9, excitation_episodes=2, twin_episodes=1, evaluation_episodes=1,
                         policy="r-dqn-realistic", identification_evaluations=30, device_trials=True)
    report = adapt(rig, tmp_path, config, say=lambda text: None)
    assert RigParams.load(tmp_path / "rig.json") != RigParams()  # something was identified
    assert (tmp_path / "policy.pt").exists() and (tmp_path / "identification.png").read_bytes()[:4] == b"\x89PNG"
    saved = json.loads((tmp_path / "report.json").read_text())
    # rig time as the rig counted it, within 9 episodes of 500 steps (270 s): 2 excitation episodes of 102
    # steps after the 7 steps that find the pendulum still, the device trials, and the one whole fine-tuning
    # episode of 500 steps left
    trials_steps = trial_steps()
    assert saved["rig_s_trials"] == pytest.approx(trials_steps * 0.06)
    assert saved["rig_s_adaptation"] == pytest.approx((2 * (REST_STEPS - 1 + 102) + trials_steps + 500) * 0.06)
    assert saved["rig_s_adaptation"] <= saved["rig_s_budget"] == pytest.approx(9 * 500 * 0.06)
    assert saved["rig_s_total"] > saved["rig_s_adaptation"]  # the evaluation came after, on the same rig
    assert report["policy_on_rig"]["summary"].startswith("solved=")
    # the identified twin's two designs and the one the trials chose, each on the rig's device
    assert set(report["classical_on_device"]) == {"energy", "trajopt", "tried"}
    assert all(len(o["solved"]) == 1 for o in report["classical_on_device"].values())
    assert sum(d["trials"] for d in saved["device_trials"]) == len(saved["device_trials"]) + FINALISTS
    assert saved["chosen_design"]["trials"] == 2 and saved["chosen_design"]["whole_solved"] is not None
    text = (tmp_path / "report.md").read_text()
    assert "| servo_speed_s_per_60deg |" in text and "run by the rig's own device" in text
    from pendkit.device.controller_blob import parse

    assert parse((tmp_path / saved["device_blob"]).read_bytes()).kind == "swing-up"  # what `pendkit deploy` takes
    assert "Device trials" in text and f"Deploy: {report['recommended'] or 'none of them'}" in text
