"""Which job a free rig takes: its servo, the instructor first, then the team with the least rig time today
(round robin when jobs are alike), teams past their quota last; and a job claimed once only (on both databases:
tests/queue/conftest.py)."""

from pendkit.queue.fair import Waiting, next_job
from pendkit.queue.store import QueueStore

WIDE, NARROW = (150, 450), (200, 400)


def waiting(job_id, team, priority=0, servo=None):
    return Waiting(job_id, team, priority, float(job_id), servo)


def test_the_rigs_servo_first_then_the_instructor_then_the_least_used_team():
    jobs = [waiting(1, "a", servo=NARROW), waiting(2, "a"), waiting(3, "b"), waiting(4, "instructor", priority=1)]
    assert next_job(jobs, WIDE, {}, {}).job_id == 4
    assert next_job(jobs[:3], WIDE, {"a": 30.0}, {}).job_id == 3  # b has used less
    assert next_job(jobs[:1], WIDE, {}, {}) is None  # made for another servo
    assert next_job(jobs[:1], NARROW, {}, {}).job_id == 1
    assert next_job(jobs[:3], WIDE, {"b": 100.0, "a": 50.0}, {"a": 40.0}).job_id == 3  # a is past its quota


def test_alike_jobs_go_round_robin_and_each_is_claimed_once(queue_url):
    store = QueueStore(queue_url)
    for team in ("a", "b", "c"):
        store.add_team(team, f"token-{team}")
    for _ in range(2):
        for team in ("a", "a", "b", "c"):  # a submits twice as often
            store.submit(team, "controller", {"controller": "energy"}, servo_range=WIDE)
    store.register_rig("r01", "bench-1", WIDE)
    order = []
    while (job := store.claim("r01", "bench-1")) is not None:
        order.append(job.team)
        assert store.claim("r01", "bench-2") is None  # r01 is busy with it: no second job
        assert [j.id for j in store.jobs(states=("running",))] == [job.id]
        store.finish(job.id, {"verdict": "test"})
    assert order[:3] in (["a", "b", "c"],) and sorted(order) == ["a"] * 4 + ["b"] * 2 + ["c"] * 2, order
    assert all(job.state == "done" for job in store.jobs())


def test_a_running_job_goes_back_to_waiting_when_its_runner_restarts(queue_url):
    store = QueueStore(queue_url)
    store.add_team("a", "token-a")
    job_id = store.submit("a", "controller", {"controller": "energy"})
    store.register_rig("r01", "bench-1", WIDE)
    assert store.claim("r01", "bench-1").id == job_id
    reopened = QueueStore(queue_url)  # the runner's process was killed and started again
    assert reopened.requeue_running("bench-1") == 1
    assert reopened.job(job_id).state == "waiting" and reopened.rigs()[0]["state"] == "free"
    assert reopened.claim("r01", "bench-1").attempts == 2
