"""A runner that pauses mid-episode (the twin's judging in the same process, a busy machine) does not drop a
team's pendulum: while the device runs its own controller the rig's watchdog waits ONBOARD_WATCHDOG_S of the
host's time, and the host-driven reset after it gets the rig's own watchdog back."""

from __future__ import annotations

import time

from pendkit.queue import runner as runner_module
from pendkit.queue.jobs import submit_job
from pendkit.queue.rig_episodes import ONBOARD_WATCHDOG_S, watchdog_command
from pendkit.queue.runner import QueueRunner
from pendkit.queue.virtual import VirtualRigs
from pendkit.rig import RigParams
from tests.queue.runner_rigs import SPEED, STEPS

PAUSE_S = 0.5  # three times a real rig's 150 ms watchdog, half the onboard one


def test_a_runner_paused_while_the_device_balances_does_not_drop_the_pendulum(store, monkeypatch):
    calls = {"n": 0}
    watch = runner_module.JobWatch.__call__

    def paused_once(self):
        calls["n"] += 1
        if calls["n"] == STEPS // 2:  # past the swing-up (3-6 s of 24 s), balancing
            time.sleep(PAUSE_S)
        watch(self)

    monkeypatch.setattr(runner_module.JobWatch, "__call__", paused_once)
    job_id = submit_job(store, "a", "controller", {"controller": "energy", "episodes": 2, "episode_steps": STEPS})
    with VirtualRigs(["r01"], SPEED) as rigs:
        QueueRunner(store, rigs.links(), "bench-1", say=lambda line: None, twin_pushes=False).run(once=True)
        watchdog_ms = rigs.group.rigs[0].device.mcu.watchdog_timeout_ms
    summary = store.result(job_id)["summary"]
    assert calls["n"] > STEPS // 2
    assert [e["held"] for e in summary["episodes"]] == [True, True], summary["verdict"]
    assert watchdog_ms == RigParams().watchdog_timeout_ms * SPEED  # the rig's own watchdog back after the job


def test_the_watchdog_command_is_in_the_hosts_time_and_the_protocols_range():
    assert watchdog_command(ONBOARD_WATCHDOG_S, 1.0) == "w1000"
    assert watchdog_command(0.15, 5.0) == "w750"  # a rig five times faster waits five times longer in its time
    assert watchdog_command(ONBOARD_WATCHDOG_S, 20.0) == "w5000"  # the protocol's longest
    assert watchdog_command(0.01, 1.0) == "w50"  # and its shortest
