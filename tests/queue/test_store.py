"""The queue's store behaves the same on an SQLite file and on a PostgreSQL server: runners in separate
processes never take one job twice, a fresh database can be opened by several at once, and what a job
carries (bytes, booleans, reasons, results) comes back as it went in."""

from __future__ import annotations

import multiprocessing

import pytest

from pendkit.errors import ConfigError
from pendkit.queue.store import MAX_ATTEMPTS, QueueStore

WIDE = (150, 450)
RUNNERS = 4  # processes claiming at once: more than the cores, so they interleave
JOBS = 40


def claim_until_none_waits(url: str, rig: str, start, taken) -> None:
    """A runner's loop in its own process: claim for `rig` and finish at once until no job waits."""
    store = QueueStore(url)
    start.wait()
    mine = []
    while store.jobs(states=("waiting",)):
        job = store.claim(rig, f"runner-{rig}")
        if job is not None:
            mine.append(job.id)
            store.finish(job.id, {"rig": rig})
    store.close()
    taken.put((rig, mine))


def open_store(url: str, name: str, start, opened) -> None:
    start.wait()
    try:
        QueueStore(url).close()
        opened.put("ok")
    except Exception as error:  # the parent asserts on what arrived
        opened.put(f"{type(error).__name__}: {error}")


def in_processes(target, url: str, names: list[str]) -> list:
    """Run `target(url, name, start, results)` in one process per name, started together; their results."""
    context = multiprocessing.get_context("spawn")
    start, results = context.Event(), context.Queue()
    processes = [context.Process(target=target, args=(url, name, start, results)) for name in names]
    for process in processes:
        process.start()
    start.set()
    gathered = [results.get(timeout=120) for _ in processes]
    for process in processes:
        process.join(timeout=60)
        assert process.exitcode == 0
    return gathered


def test_runners_in_separate_processes_never_take_the_same_job_twice(queue_url):
    store = QueueStore(queue_url)
    for team in ("a", "b", "c"):
        store.add_team(team, f"token-{team}")
    submitted = [store.submit("abc"[k % 3], "controller", {"controller": "energy"}, servo_range=WIDE)
                 for k in range(JOBS)]
    rig_names = [f"r{k:02d}" for k in range(RUNNERS)]
    for rig in rig_names:
        store.register_rig(rig, f"runner-{rig}", WIDE)
    taken = in_processes(claim_until_none_waits, queue_url, rig_names)
    claimed = [job_id for _, mine in taken for job_id in mine]
    assert sorted(claimed) == submitted  # every job once, none twice
    assert all(job.state == "done" and job.attempts == 1 for job in store.jobs())
    ran_on = {job_id: store.result(job_id)["summary"]["rig"] for job_id in submitted}
    assert all(ran_on[job_id] == rig for rig, mine in taken for job_id in mine)
    assert {rig["state"] for rig in store.rigs()} == {"free"}


def test_several_runners_can_open_a_fresh_database_at_once(queue_url):
    """Runners on several machines started together against an empty database: each creates the tables if
    they are missing, and none fails because another did it first."""
    assert in_processes(open_store, queue_url, [str(k) for k in range(RUNNERS)]) == ["ok"] * RUNNERS
    assert QueueStore(queue_url).jobs() == []


def test_what_a_job_carries_comes_back_as_it_went_in(queue_url):
    store = QueueStore(queue_url)
    store.add_team("a", "token-a", quota_rig_s=600.0)
    store.add_team("teacher", "token-t", instructor=True)
    payload = bytes(range(256)) * 4  # a blob: every byte value, NUL included
    job_id = store.submit("a", "blob", {"episodes": 3, "name": "ünïcode"}, payload=payload, servo_range=WIDE)
    job = store.job(job_id)
    assert (job.payload, job.spec, job.servo_range, job.state) == (payload, {"episodes": 3, "name": "ünïcode"},
                                                                    WIDE, "waiting")
    assert store.job(job_id, team="teacher") is None  # another team's job is not found
    assert store.team_for_token("token-t") == ("teacher", True)
    assert store.team_for_token("token-a") == ("a", False)
    assert store.team_for_token("token-x") is None
    store.register_rig("r01", "bench-1", WIDE)
    assert store.claim("r01", "bench-1").id == job_id
    assert store.finish(job_id, {"verdict": "pass", "time_to_upright_s": [1.5]}, telemetry_csv="t_s,angle\n0,3.1\n",
                        plot_png=b"\x89PNG\r\n\x1a\n")
    result = store.result(job_id)
    assert result == {"summary": {"verdict": "pass", "time_to_upright_s": [1.5]},
                      "telemetry_csv": "t_s,angle\n0,3.1\n", "plot_png": b"\x89PNG\r\n\x1a\n"}


def test_a_job_for_a_team_the_queue_does_not_know_is_refused_on_both(queue_url):
    store = QueueStore(queue_url)
    with pytest.raises(ConfigError, match="unknown team 'nobody'") as refused:
        store.submit("nobody", "controller", {"controller": "energy"})
    assert "\n" not in str(refused.value)
    assert store.jobs() == []


def test_cancel_belongs_to_the_team_and_a_cancelled_job_keeps_its_result(queue_url):
    store = QueueStore(queue_url)
    store.add_team("a", "token-a")
    store.add_team("b", "token-b")
    job_id = store.submit("a", "controller", {"controller": "energy"})
    store.register_rig("r01", "bench-1", None)
    assert store.claim("r01", "bench-1").id == job_id
    assert not store.cancel(job_id, team="b")  # not b's to cancel
    assert store.cancel(job_id, team="a")
    assert not store.finish(job_id, {"verdict": "stopped"})  # the runner finishes after the cancel
    assert store.job(job_id).state == "cancelled" and store.result(job_id)["summary"] == {"verdict": "stopped"}
    assert store.rigs()[0]["state"] == "free"


def test_a_job_that_keeps_losing_its_rig_fails_with_every_reason(queue_url):
    store = QueueStore(queue_url)
    store.add_team("a", "token-a")
    job_id = store.submit("a", "controller", {"controller": "energy"})
    for k in range(MAX_ATTEMPTS):
        store.register_rig(f"r{k}", "bench-1", None)
        assert store.claim(f"r{k}", "bench-1").id == job_id
        store.take_out(f"r{k}", "did not settle in 30 s")
        state = store.requeue(job_id, f"r{k} did not settle")
    job = store.job(job_id)
    assert state == "failed" and job.state == "failed" and job.attempts == MAX_ATTEMPTS
    assert job.reason == "; ".join(f"r{k} did not settle" for k in range(MAX_ATTEMPTS))
    assert [rig["state"] for rig in store.rigs()] == ["out"] * MAX_ATTEMPTS


def test_a_rig_out_of_service_takes_nothing_until_put_back_and_a_silent_runners_job_runs_again(queue_url):
    store = QueueStore(queue_url)
    store.add_team("a", "token-a")
    first = store.submit("a", "controller", {"controller": "energy"})
    store.register_rig("r01", "bench-1", None)
    store.register_rig("r02", "bench-2", None)
    store.take_out("r01", "safety stop: arm at its limit")
    assert store.claim("r01", "bench-1") is None
    store.register_rig("r01", "bench-1", None)  # its runner restarting does not put it back
    assert store.rigs()[0]["state"] == "out" and store.rigs()[0]["reason"] == "safety stop: arm at its limit"
    assert store.claim("r02", "bench-2").id == first
    assert store.requeue_stale(max_age_s=-1.0) == 1  # bench-2 went silent
    assert store.job(first).state == "waiting" and "stopped answering" in store.job(first).reason
    assert store.put_back("r01") and store.claim("r01", "bench-1").id == first
