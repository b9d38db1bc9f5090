"""`pendkit queue run` as a command: it serves virtual rigs until the queue is empty (`--once`), and a runner
process killed mid-job (SIGKILL: no clean-up at all) and started again loses nothing: the job it left running
runs again, the results it stored stay as they were. And the kit's rule in full: ten episodes of the energy
swing-up on a virtual rig."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import pytest
from click.testing import CliRunner

from pendkit.cli import main
from pendkit.queue.jobs import submit_job
from pendkit.queue.runner import QueueRunner
from pendkit.queue.virtual import VirtualRigs
from tests.queue.runner_rigs import SHORT, SPEED, STEPS, wait_for


def test_queue_run_serves_virtual_rigs_until_the_queue_is_empty(store):
    job_id = submit_job(store, "a", "controller", {"controller": "energy", **SHORT})
    done = CliRunner().invoke(main, ["queue", "run", "--db", store.url, "--virtual", "r01", "--speed", str(SPEED),
                                     "--once", "--no-twin", "--name", "bench-1"])
    assert done.exit_code == 0, done.output
    assert f"r01: serving (servo 150..450 counts, {SPEED:g}x)" in done.output
    assert f"r01: job {job_id} done: 1/1" in done.output and "runner bench-1 stopped" in done.output
    assert store.job(job_id).state == "done"


def test_queue_run_needs_rigs():
    done = CliRunner().invoke(main, ["queue", "run", "--db", "sqlite:///unused.db"])
    assert done.exit_code == 2 and "give the rigs to serve" in done.output


def runner_process(url: str, *options: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "pendkit.cli", "queue", "run", "--db", url, "--virtual", "r01",
                             "--speed", str(SPEED), "--name", "bench-1", "--no-twin", *options],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


@pytest.mark.expensive
def test_a_runner_killed_mid_job_and_started_again_loses_nothing(store):
    jobs = [submit_job(store, "a", "controller", {"controller": "energy", "episodes": 2, "episode_steps": STEPS})
            for _ in range(3)]
    process = runner_process(store.url)
    try:
        wait_for(lambda: store.job(jobs[0]).state == "done" and store.job(jobs[1]).state == "running",
                 timeout_s=180)
        os.kill(process.pid, signal.SIGKILL)
        process.wait(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
    first = store.result(jobs[0])
    assert store.job(jobs[1]).state == "running"  # left so by the dead runner
    again = runner_process(store.url, "--once")
    output, _ = again.communicate(timeout=300)
    assert again.returncode == 0, output
    assert "1 job(s) it left running went back to waiting" in output
    assert [store.job(j).state for j in jobs] == ["done"] * 3
    assert store.result(jobs[0]) == first  # a stored result is never touched again
    assert store.job(jobs[1]).attempts == 2 and "the runner restarted" in store.result(jobs[1])["summary"][
        "earlier_attempts"]
    assert all(store.result(j)["summary"]["verdict"] == "2/2" for j in jobs)


@pytest.mark.expensive
def test_the_energy_swing_up_holds_by_the_kits_rule_on_a_virtual_rig(store):
    job_id = submit_job(store, "a", "controller", {"controller": "energy"})  # ten episodes of 500 steps
    with VirtualRigs(["r01"], SPEED) as rigs:
        QueueRunner(store, rigs.links(), "bench-1", say=lambda line: None).run(once=True)
    summary = store.result(job_id)["summary"]
    assert store.job(job_id).state == "done" and summary["episodes_run"] == 10
    assert summary["solved"] is True and summary["held"] >= 9, summary["verdict"]
    assert summary["pushes"]["episodes"] == 10  # the twin's column of the leaderboard, judged too
