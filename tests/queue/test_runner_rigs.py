"""The runner on virtual rigs over the embedded broker (the twin as rigs, at 20x): jobs judged with their
telemetry and plot, hostile jobs stopped or refused while the rig stays in service, a job for another servo
kept for a rig of that servo, a rig killed mid-job taken out with its job run again elsewhere, cancel and the
time limit ending a job with the controller stopped on the rig, the reset between episodes, an excitation
handed back."""

from __future__ import annotations

import json
import time

import pytest

from pendkit.adapt.excitation import Recording
from pendkit.adapt.queued import record_excitation
from pendkit.deploy.on_rig import RigSession, upload_to_rig
from pendkit.deploy.swingup_design import design_swing_up
from pendkit.device.controller_blob import pack
from pendkit.queue.job_results import CSV_HEADER, save_excitation
from pendkit.queue.jobs import EXCITATION_STEPS, submit_job
from pendkit.queue.rig_reset import spread_counts
from pendkit.queue.runner import QueueRunner
from pendkit.queue.store import QueueStore
from pendkit.queue.virtual import VirtualRigs
from pendkit.rig import RigParams
from tests.queue.runner_rigs import SHORT, SPEED, STEPS, network_blob, serving, spinner_blob, wait_for

ENERGY = {"controller": "energy", **SHORT}


def runner_for(store, rigs, name="bench-1", **options):
    return QueueRunner(store, rigs.links(), name, say=lambda line: None, **options)


def rows_of(csv_text: str) -> list[list[str]]:
    lines = csv_text.splitlines()
    assert lines[0] == CSV_HEADER
    return [line.split(",") for line in lines[1:]]


def test_a_controller_job_is_judged_by_the_rule_with_its_telemetry_and_plot(queue_url):
    store = QueueStore(queue_url)
    store.add_team("a", "token-a")
    job_id = submit_job(store, "a", "controller", {"controller": "energy", "episodes": 2, "episode_steps": STEPS})
    with VirtualRigs(["r01"], SPEED) as rigs:
        runner_for(store, rigs).run(once=True)
    job, result = store.job(job_id), store.result(job_id)
    summary = result["summary"]
    assert job.state == "done" and summary["rig"] == "r01"
    assert summary["verdict"] == "2/2" and [e["held"] for e in summary["episodes"]] == [True, True]
    assert all(0 < e["time_to_upright_s"] < (STEPS - 200) * 0.06 for e in summary["episodes"])
    assert len(summary["reset_s"]) == 2
    rows = rows_of(result["telemetry_csv"])
    assert [sum(row[0] == str(k) for row in rows) for k in (1, 2)] == [STEPS, STEPS]  # a row per control step
    first = [float(row[1]) for row in rows if row[0] == "1"]
    assert first == sorted(first) and first[-1] > 0.9 * STEPS * 0.06  # the device's clock, 60 ms a step
    assert result["plot_png"][:8] == b"\x89PNG\r\n\x1a\n"
    assert summary["pushes"]["episodes"] == 2 and summary["pushes"]["size"] == "hand"  # the twin, judged too
    assert store.rigs()[0]["state"] == "free"
    store.close()


def test_hostile_jobs_are_stopped_or_refused_and_the_rig_stays_in_service(store):
    spinner = submit_job(store, "a", "blob", {"episodes": 2, "episode_steps": 500}, spinner_blob())
    # a job that skipped the submission's checks (written to the database directly): the device refuses it
    refused = store.submit("a", "blob", {"kind": "blob", "episodes": 1, "episode_steps": STEPS, "control_step_s": 0.06,
                                         "params": RigParams().to_dict()}, network_blob(), (150, 450))
    after = submit_job(store, "a", "controller", ENERGY)
    with VirtualRigs(["r01"], SPEED) as rigs:
        runner_for(store, rigs).run(once=True)
        assert not rigs.group.rigs[0].device.mcu.onboard.running  # stopped on the rig, not left running
    spun = store.job(spinner)
    assert spun.state == "failed" and "drove the arm against its end stops" in spun.reason
    flags = [row[5] for row in rows_of(store.result(spinner)["telemetry_csv"])]
    assert sum("arm_limit" in f for f in flags) > len(flags) / 2  # the device clipped it at the end stops
    assert store.job(refused).state == "failed"
    assert "the rig refused the blob: a network controller: this device runs swing-up, policy" in \
        store.job(refused).reason
    assert store.job(after).state == "done" and store.result(after)["summary"]["verdict"] == "1/1"
    assert store.rigs()[0]["state"] == "free"


def test_a_twin_figure_left_pending_by_a_killed_runner_is_judged_by_the_next(store):
    from pendkit.queue.runner import TWIN_PENDING

    job_id = submit_job(store, "a", "controller", ENERGY)
    store.register_rig("r09", "a-runner-since-killed", (150, 450))
    store.claim("r09", "a-runner-since-killed")
    store.finish(job_id, {"verdict": "1/1", "held": 1, "episodes_run": 1, "pushes": TWIN_PENDING})
    with VirtualRigs(["r01"], SPEED) as rigs:
        runner_for(store, rigs).run(once=True)
    pushes = store.result(job_id)["summary"]["pushes"]
    assert pushes["episodes"] == 1 and pushes["size"] == "hand"
    assert store.result(job_id)["summary"]["verdict"] == "1/1"  # the rig's figures as they were


def test_a_job_for_another_servo_waits_for_a_rig_of_that_servo(store):
    turnigy = submit_job(store, "a", "controller", {**ENERGY, "preset": "turnigy-tgy-wp23"})
    default = submit_job(store, "a", "controller", ENERGY)
    with VirtualRigs(["r01"], SPEED) as rigs:
        runner_for(store, rigs).run(once=True)  # stops with the Turnigy job still waiting: no rig of its servo
    assert store.job(default).state == "done" and store.job(turnigy).state == "waiting"
    with VirtualRigs(["r03"], SPEED, params=RigParams.preset("turnigy-tgy-wp23")) as rigs:
        runner_for(store, rigs, "bench-2").run(once=True)
    assert store.job(turnigy).state == "done" and store.job(turnigy).rig == "r03"
    assert store.result(turnigy)["summary"]["verdict"] == "1/1"


def test_a_rig_killed_mid_job_is_taken_out_and_its_job_runs_on_another(store):
    job_id = submit_job(store, "a", "controller", {"controller": "energy", "episodes": 2, "episode_steps": 400})
    with VirtualRigs(["r01", "r02"], SPEED) as rigs, serving(runner_for(store, rigs)):
        first = wait_for(lambda: store.job(job_id).rig)
        device = next(rig for rig in rigs.group.rigs if rig.rig == first).device.mcu.onboard
        wait_for(lambda: device.running)  # mid-episode
        rigs.kill(first)
        wait_for(lambda: store.job(job_id).state == "done")
    job, out = store.job(job_id), {r["rig"]: r for r in store.rigs()}
    other = ({"r01", "r02"} - {first}).pop()
    assert job.attempts == 2 and job.rig == other and store.result(job_id)["summary"]["verdict"] == "2/2"
    assert out[first]["state"] == "out" and f"rig {first} sent no reading" in out[first]["reason"]
    assert f"rig {first} sent no reading" in job.reason  # the team sees why it ran twice


def test_a_rig_gone_while_idle_is_taken_out_before_it_costs_a_job_an_attempt(store):
    with VirtualRigs(["r01", "r02"], SPEED) as rigs, serving(runner_for(store, rigs)):
        rigs.kill("r02")
        wait_for(lambda: any(r["rig"] == "r02" and r["state"] == "out" for r in store.rigs()))
        job_id = submit_job(store, "a", "controller", ENERGY)
        wait_for(lambda: store.job(job_id).state == "done")
    assert store.job(job_id).rig == "r01" and store.job(job_id).attempts == 1


def test_cancel_stops_the_controller_and_keeps_what_ran(store):
    long = submit_job(store, "a", "controller", {"controller": "energy", "episodes": 5})
    after = submit_job(store, "a", "controller", ENERGY)
    with VirtualRigs(["r01"], SPEED) as rigs, serving(runner_for(store, rigs)):
        wait_for(lambda: store.job(long).state == "running")
        device = rigs.group.rigs[0].device.mcu.onboard
        # its first episode under way, a second of it run (a loaded machine may start the runner's samples late)
        wait_for(lambda: device.running and device.runtime.steps >= 15)
        assert store.cancel(long, "a")
        wait_for(lambda: store.result(long) is not None)
        assert not device.running
        wait_for(lambda: store.job(after).state == "done")
    job, summary = store.job(long), store.result(long)["summary"]
    assert job.state == "cancelled" and summary["stopped"] == "cancelled"
    assert summary["episodes_run"] >= 1 and summary["verdict"].endswith("/5")
    assert rows_of(store.result(long)["telemetry_csv"])  # the telemetry of what ran is kept


def test_the_time_limit_stops_the_controller_and_the_servo_holds(store):
    job_id = submit_job(store, "a", "controller", {"controller": "energy", "episodes": 3, "episode_steps": 500,
                                                   "time_limit_s": 40})
    with VirtualRigs(["r01"], SPEED) as rigs:
        runner_for(store, rigs).run(once=True)
        device = rigs.group.rigs[0].device
        assert not device.mcu.onboard.running and device.mcu.command.mode == "discrete"  # `k0`, then `d`: held
        assert device.mcu.command.increment_counts == 0
    job, result = store.job(job_id), store.result(job_id)
    assert job.state == "failed" and "its time limit ran out (40 s of the rig's time)" in job.reason
    assert result["summary"]["verdict"].endswith("/3") and result["summary"]["episodes_run"] == 2
    assert 500 <= len(rows_of(result["telemetry_csv"])) < 1000  # the first episode whole, the second cut short


def test_the_reset_leaves_the_pendulum_hanging_still_and_the_arm_centred_or_says_it_cannot():
    from pendkit.queue.rig_episodes import start_controller
    from pendkit.queue.rig_reset import RigFault, reset_rig

    params = RigParams()
    with VirtualRigs(["r01"], SPEED) as rigs:
        link = rigs.links()[0]
        link.connect()
        session = RigSession(link)
        session.command(f"w{round(params.watchdog_timeout_ms * SPEED)}")  # as the runner sets a fast rig's
        upload_to_rig(session, pack(design_swing_up(params, "energy")))

        def drop_from_upright() -> None:
            reset_rig(session, params, SPEED)
            start_controller(session, lambda: None)
            wait_for(lambda: session.command("h") or
                     abs(link.newest.received.observation.position_counts - 512) < 10, every_s=0.05 / SPEED)
            session.command("k0")  # the pendulum falls

        drop_from_upright()
        with pytest.raises(RigFault, match="did not hang still within 1 s"):
            reset_rig(session, params, SPEED, limit_s=1.0)
        drop_from_upright()
        reset_rig(session, params, SPEED)
        readings = []
        for _ in range(20):  # the next second of the rig's
            session.command("h")
            time.sleep(0.05 / SPEED)
            readings.append(link.newest.received.observation)
        assert spread_counts([r.position_counts for r in readings]) <= 3
        assert {r.servo_counts for r in readings} == {round(params.servo_centre_counts)}
        link.close()


def test_an_excitation_is_recorded_and_handed_back(store, tmp_path):
    job_id = submit_job(store, "a", "excitation", {"episodes": 2})
    # slower than the other tests: the recording's checks hold the device's clock to the laptop's, and a virtual
    # rig at 20x, or at 5x on a machine loaded by four test workers, falls behind (refused, rightly: "the
    # device's clock ran 5.8 s in 7.4 s")
    with VirtualRigs(["r01"], 2.0) as rigs:
        runner_for(store, rigs, excitation=record_excitation).run(once=True)
    job, result = store.job(job_id), store.result(job_id)
    assert job.state == "done" and result["summary"]["recorded_episodes"] == 2
    path = save_excitation(result, tmp_path / "mine")
    recordings = [Recording.from_dict(item) for item in json.loads(path.read_text())]
    assert [len(r.actions) for r in recordings] == [EXCITATION_STEPS, EXCITATION_STEPS]
    assert all(r.device is not None and len(r.device.ms) > 100 for r in recordings)  # the device's own clock
    assert (tmp_path / "mine" / "telemetry.csv").read_text().startswith(CSV_HEADER)
