"""`pendkit train --resume` after kill -9: nothing lost beyond the last checkpoint, and the resumed run
is the run that was never interrupted (every RNG is in the checkpoint)."""

import csv
import signal
import subprocess
import sys
import time

import pytest
from click.testing import CliRunner

pytest.importorskip("torch")

from pendkit.cli import main  # noqa: E402

ARGS = ["--episodes", "16", "--max-steps", "40", "--checkpoint-every", "4", "--seed", "3", "--quiet"]


def returns_of(folder):
    with (folder / "returns.csv").open() as handle:
        return [(int(row["episode"]), float(row["return"])) for row in csv.DictReader(handle)]


def test_resume_after_kill_9_continues_the_same_run(tmp_path):
    straight = tmp_path / "straight"
    result = CliRunner().invoke(main, ["train", *ARGS, "--out", str(straight)])
    assert result.exit_code == 0, result.output

    killed = tmp_path / "killed"
    process = subprocess.Popen([sys.executable, "-m", "pendkit.cli", "train", *ARGS, "--out", str(killed)],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if (killed / "returns.csv").exists() and len(returns_of(killed)) >= 9:
            break
        time.sleep(0.05)
    process.send_signal(signal.SIGKILL)
    process.wait()
    assert (killed / "checkpoint.pt").exists() and len(returns_of(killed)) < 16  # killed mid-run

    result = CliRunner().invoke(main, ["train", *ARGS, "--out", str(killed), "--resume"])
    assert result.exit_code == 0, result.output
    resumed = returns_of(killed)
    assert [episode for episode, _ in resumed] == list(range(16))  # every episode once, none twice
    assert [r for _, r in resumed] == pytest.approx([r for _, r in returns_of(straight)], abs=1e-3)


@pytest.mark.parametrize("algo", ["r-dqn", "td3", "r-td3"])
def test_eval_and_plot_of_a_run(tmp_path, algo):
    run = tmp_path / "run"
    result = CliRunner().invoke(main, ["train", "--algo", algo, "--episodes", "3", "--max-steps", "30",
                                       "--out", str(run), "--quiet"])
    assert result.exit_code == 0, result.output
    result = CliRunner().invoke(main, ["eval", str(run), "--episodes", "2"])
    assert result.exit_code == 0, result.output
    assert result.output.splitlines()[-1] == "solved=0/2 median_upright_s=-"  # 30 steps cannot hold 200
    result = CliRunner().invoke(main, ["plot", str(run)])
    assert result.exit_code == 0 and (run / "learning-curve.png").read_bytes()[:4] == b"\x89PNG"


def test_train_on_a_virtual_rig_with_the_non_blocking_trainer(tmp_path):
    from pendkit.link.virtual_rig import LocalRig

    rig = LocalRig()
    try:
        result = CliRunner().invoke(main, ["train", "--backend", "rig", "--broker", rig.url, "--rig", rig.rig,
                                           "--seconds", "3", "--max-steps", "20", "--out", str(tmp_path / "rig")])
        assert result.exit_code == 0, result.output
        assert "learner updates" in result.output and (tmp_path / "rig" / "final.pt").exists()
        assert len(returns_of(tmp_path / "rig")) >= 1
        # ...and evaluated on the same rig: its 20-step episodes run there, and cannot hold 200 steps
        result = CliRunner().invoke(main, ["eval", str(tmp_path / "rig"), "--backend", "rig", "--broker", rig.url,
                                           "--rig", rig.rig, "--episodes", "2"])
    finally:
        rig.stop()
    assert result.exit_code == 0, result.output
    assert result.output.splitlines()[-1] == "solved=0/2 median_upright_s=-"
    assert rig.virtual.commands_received >= 2 * 20  # counted by the rig itself, beside the host's bookkeeping


def test_eval_of_a_shipped_policy_on_its_twin_and_bad_requests():
    result = CliRunner().invoke(main, ["eval", "--policy", "dqn-ideal", "--episodes", "3", "--start", "rest"])
    assert result.exit_code == 0, result.output
    last = result.output.splitlines()[-1]
    # the time to upright is simulated seconds of the seeded twin, not wall time
    assert last.startswith("solved=3/3 median_upright_s=") and 0.5 < float(last.split("=")[-1]) < 6, last
    assert CliRunner().invoke(main, ["eval", "--episodes", "1"]).exit_code == 2  # neither a run nor a policy
    unknown = CliRunner().invoke(main, ["eval", "--policy", "no-such-policy"])
    assert unknown.exit_code == 1 and "the kit ships" in unknown.output
