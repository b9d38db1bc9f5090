"""`pendkit eval --controller` runs a classical swing-up from the laptop and judges it by the kit's rule, on
the twin and on a (virtual) rig; `deploy` ends with the same verdict; neither drives a rig whose servo is not
the one the controller or policy was made for."""

import pytest
from click.testing import CliRunner

from pendkit.cli import main
from pendkit.deploy.on_rig import deploy_verdict
from pendkit.link.virtual_rig import LocalRig
from pendkit.rig import RigParams


def test_energy_swing_up_is_judged_by_the_rule_on_the_twin():
    result = CliRunner().invoke(main, ["eval", "--controller", "energy", "--episodes", "10"])
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert sum(line.startswith("episode ") for line in lines) == 10
    verdict = next(line for line in lines if line.startswith("controller: "))
    held = int(verdict.split("controller_solved=")[1].split("/")[0])
    assert held >= 9 and "(yes)" in verdict and "rest=" in verdict and "random=" in verdict, result.output
    assert lines[-1].startswith(f"solved={held}/10 median_upright_s=")


def test_the_controller_is_designed_for_the_servo_preset_given():
    result = CliRunner().invoke(main, ["eval", "--controller", "trajopt", "--preset", "turnigy-tgy-wp23",
                                       "--episodes", "2", "--start", "rest"])
    assert result.exit_code == 0, result.output
    assert "designed for Turnigy TGY-WP23" in result.output
    assert "controller: not judged" in result.output  # 2 episodes are not the rule


def test_one_source_only():
    result = CliRunner().invoke(main, ["eval", "--controller", "energy", "--policy", "dqn-ideal"])
    assert result.exit_code == 2 and "give one of RUN_DIR, --policy NAME or --controller" in result.output


@pytest.mark.parametrize("samples, expected", [
    ([(0.05 * k, 2.0 if k < 40 else 0.1) for k in range(200)], "verdict: held"),  # up at 2 s, 10 s run
    ([(0.05 * k, 0.1 if k < 150 else 1.0) for k in range(200)], "verdict: not held (not within 0.3 rad"),
    ([(0.05 * k, 0.1) for k in range(40)], "verdict: not held (ran 2.0 s, the rule needs the last 4 s"),  # too short
    ([], "verdict: not judged (no telemetry"),
])
def test_the_deploy_verdict_follows_the_rules_tail(samples, expected):
    line = deploy_verdict(samples, 0.02)
    assert line.startswith(expected), line
    assert line.endswith(("solved=1/1 median_upright_s=2.00", "solved=0/1 median_upright_s=-")), line


@pytest.mark.expensive
def test_energy_swing_up_from_the_laptop_holds_a_virtual_rig_and_a_deploy_says_so():
    rig = LocalRig()
    try:
        evaluated = CliRunner().invoke(main, ["eval", "--controller", "energy", "--backend", "rig", "--broker",
                                              rig.url, "--rig", rig.rig, "--episodes", "1"])
        deployed = CliRunner().invoke(main, ["deploy", "--controller", "energy", "--rig", rig.rig, "--broker",
                                             rig.url, "--seconds", "14"])
    finally:
        rig.stop()
    assert evaluated.exit_code == 0, evaluated.output
    assert evaluated.output.splitlines()[-1].startswith("solved=1/1"), evaluated.output
    assert deployed.exit_code == 0, deployed.output
    assert deployed.output.splitlines()[-1].startswith("verdict: held"), deployed.output


@pytest.mark.expensive
def test_eval_and_deploy_refuse_a_rig_with_another_servo_naming_both(tmp_path):
    run = tmp_path / "turnigy-run"
    trained = CliRunner().invoke(main, ["train", "--algo", "r-dqn", "--episodes", "1", "--max-steps", "10",
                                        "--preset", "turnigy-tgy-wp23", "--out", str(run), "--quiet"])
    assert trained.exit_code == 0, trained.output
    rig = LocalRig()  # the kit's rig: Hitec D645MW, counts 150..450
    try:
        outcomes = [CliRunner().invoke(main, command + ["--broker", rig.url, "--rig", rig.rig]) for command in (
            ["deploy", str(run), "--seconds", "1"],
            ["eval", str(run), "--backend", "rig", "--episodes", "1"],
            ["eval", "--controller", "energy", "--preset", "turnigy-tgy-wp23", "--backend", "rig", "--episodes", "1"],
        )]
        accepted = rig.virtual.device.mcu.onboard.blobs_accepted
    finally:
        rig.stop()
    narrow, wide = RigParams.preset("turnigy-tgy-wp23"), RigParams()
    for outcome in outcomes:
        assert outcome.exit_code == 1 and "Traceback" not in outcome.output, outcome.output
        message = outcome.output.strip().splitlines()[-1]
        assert f"{wide.servo_min_counts}..{wide.servo_max_counts}" in message and "hitec-d645mw" in message, message
        assert f"{narrow.servo_min_counts}..{narrow.servo_max_counts} (Turnigy TGY-WP23" in message, message
        assert "--preset hitec-d645mw" in message and "--params RIG.json" in message, message
    assert "not uploaded" in outcomes[0].output and accepted == 0
