"""`pendkit sweep` through Ray on this machine: a killed sweep resumed on the local Ray the sweep starts, and
the smoke spec on a two-node cluster (`ray start --head` and a second `ray start --address`) whose trials
land on both nodes, then reported. One file: the tests run one after another on one worker, so their Ray
instances never meet; each Ray start costs about 18 s of CPU, so no test starts one it does not need."""

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("ray", reason='the sweep needs the cluster extra: pip install -e ".[cluster]"')
pytestmark = pytest.mark.expensive  # about 90 s, mostly waiting on Ray: scheduled first (conftest.py)

ROOT = Path(__file__).resolve().parents[2]
SMOKE = ROOT / "benchmarks" / "sweeps" / "smoke.yaml"
PENDKIT = [sys.executable, "-m", "pendkit.cli"]
RAY = str(Path(sys.executable).parent / "ray")
HANG_GUARD_S = 900  # guards against a hang, not a pace: a loaded 2-core machine is slow in bursts


def pendkit(*args, env=None, timeout=HANG_GUARD_S) -> subprocess.CompletedProcess:
    return subprocess.run([*PENDKIT, *args], capture_output=True, text=True, timeout=timeout, env=env, cwd=ROOT)


def rows(out: Path) -> dict[str, dict]:
    return {p.parent.name: json.loads(p.read_text()) for p in (out / "trials").glob("*/result.json")}


def _spec(path: Path, max_episodes: int) -> Path:
    path.write_text("name: resume\nlearners: [dqn]\nfidelities: [ideal]\nseeds: 2\n"
                    f"budget: {{max_episodes: {max_episodes}, max_wall_s: 600, check_every: 2}}\n"
                    "agent: {learning_starts: 200}\n")
    return path


def test_a_killed_sweep_resumes_without_redoing_finished_trials(tmp_path):
    spec, out = _spec(tmp_path / "resume.yaml", 8), tmp_path / "resume"
    # two CPUs per trial on a two-CPU machine: one trial at a time, seed 0 then seed 1
    said = tmp_path / "first-run.txt"  # what the first run said, for a failure's message
    with said.open("w") as to_file:
        sweep = subprocess.Popen([*PENDKIT, "sweep", str(spec), "--out", str(out), "--cpus-per-trial", "2"],
                                 cwd=ROOT, stdout=to_file, stderr=subprocess.STDOUT, start_new_session=True)
    first, second = out / "trials" / "dqn--ideal--seed0", out / "trials" / "dqn--ideal--seed1"
    deadline = time.monotonic() + HANG_GUARD_S
    while not ((first / "result.json").exists() and (second / "checks.csv").exists()):
        assert sweep.poll() is None, f"the sweep ended before it could be killed:\n{said.read_text()[-3000:]}"
        assert time.monotonic() < deadline, "the sweep never reached its second trial"
        time.sleep(0.2)
    os.killpg(sweep.pid, signal.SIGKILL)  # the driver and everything it started
    sweep.wait()
    assert not (second / "result.json").exists()
    finished_before = (first / "result.json").read_text()
    stamp = (first / "result.json").stat().st_mtime_ns
    resumed = pendkit("sweep", str(spec), "--out", str(out), "--resume")
    assert resumed.returncode == 0, resumed.stdout + resumed.stderr
    assert "1 of 2 trials already finished" in resumed.stdout
    assert "Ray up in" in resumed.stdout and "1 node(s)" in resumed.stdout  # a local Ray, started by the sweep
    assert (first / "result.json").read_text() == finished_before
    assert (first / "result.json").stat().st_mtime_ns == stamp
    row = json.loads((second / "result.json").read_text())
    assert row["resumed_from_episode"] >= 2 and row["episodes"] == 8
    assert row["niceness"] == os.nice(0)  # not Ray's default 15, which starves a trial beside any other work
    episodes = [line.split(",")[0] for line in (second / "curve.csv").read_text().splitlines()[1:]]
    assert episodes == [str(k) for k in range(8)]  # continued from the checkpoint: no episode twice or lost


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@pytest.fixture
def two_node_cluster():
    # Ray's token authentication: a token in ~/.ray/auth_token (made if missing), every process told to use it
    env = {**os.environ, "RAY_AUTH_MODE": "token"}
    subprocess.run([RAY, "get-auth-token", "--generate"], capture_output=True, env=env)  # older Rays: no-op
    port = _free_port()
    common = ["--num-cpus", "1", "--disable-usage-stats"]
    try:
        head = subprocess.run([RAY, "start", "--head", "--port", str(port), "--include-dashboard", "false",
                               "--node-ip-address", "127.0.0.1", *common], capture_output=True, text=True, env=env)
        assert head.returncode == 0, head.stdout + head.stderr
        worker = subprocess.run([RAY, "start", "--address", f"127.0.0.1:{port}", "--node-ip-address", "127.0.0.1",
                                 *common], capture_output=True, text=True, env=env)
        assert worker.returncode == 0, worker.stdout + worker.stderr
        yield f"127.0.0.1:{port}", env
    finally:
        subprocess.run([RAY, "stop", "--force"], capture_output=True, env=env)


def test_the_smoke_spec_runs_on_a_two_node_cluster_with_trials_on_both_and_reports_a_line_per_trial(
        two_node_cluster, tmp_path):
    address, env = two_node_cluster
    out = tmp_path / "smoke"
    run = pendkit("sweep", str(SMOKE), "--out", str(out), "--address", address, env=env)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "Ray up in" in run.stdout and "2 node(s), 2 CPUs" in run.stdout
    finished = rows(out)
    assert sorted(finished) == ["dqn--ideal--seed0", "dqn--ideal--seed1"]
    assert len({row["node_id"] for row in finished.values()}) == 2, f"both trials ran on one node: {finished}"
    for row in finished.values():
        assert row["episodes"] == 4 and row["solved"] is False
        curve = (out / row["curve"]).read_text().splitlines()
        assert curve[0] == "episode,return" and len(curve) == 1 + 4
    report = pendkit("sweep", "report", str(out))
    assert report.returncode == 0, report.stderr
    trial_lines = [line for line in report.stdout.splitlines() if line.startswith("trial=")]
    assert len(trial_lines) == 2 and all("solved=False" in line for line in trial_lines)
    assert "algo=dqn fidelity=ideal solved=0/2" in report.stdout
    table = (out / "table.csv").read_text().splitlines()
    assert table[0].startswith("trial_id,learner,setting_name,seed,solved") and len(table) == 3
    assert (out / "summary.png").stat().st_size > 1000
    again = pendkit("sweep", str(SMOKE), "--out", str(out), "--address", address, env=env)
    assert again.returncode != 0 and "--resume" in again.stderr  # never overwrites a sweep by accident
