"""Lab tasks judged on a rig (issue 69 part 7; lab 10's `10.deploy` first): the blob a student's function returns,
checked by the device's own parser, then judged by the kit's rule (>= 9 of 10 episodes held upright at the end).

Without a queue the blob is judged on the twin's device from the rule's starts, and the feedback says so. With
one (`pendkit grade --queue-server URL` or `--queue-db URL`) grading takes two steps. While a notebook is graded,
its test checks the blob and keeps it (`Pending`: no points yet). Once every notebook is graded and every
student's kernel has ended, `judge_on_rigs` submits the kept blobs as jobs of the instructor's team, waits for
the rigs' verdicts and turns each into the test's marks, the verdict in its feedback. The queue's token is used
in that second step only, in the command's own process: it is never in a student's kernel (whose environment is
`runner.kernel_environment`'s short list) nor in a grading worker's.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from pendkit.deploy.on_twin import DeployError, onboard_episode, upload_to_twin
from pendkit.env_name import EPISODE_STEPS
from pendkit.errors import ConfigError, PendkitError
from pendkit.features import SOLVED_TAIL_STEPS, holds_upright, time_to_upright_s
from pendkit.grading.core import Failed, Pending
from pendkit.queue.client import QueueClient

# pendkit modules that load torch, MuJoCo and SQLAlchemy are imported inside the functions that use them: importing
# this module does not need them (start-up; torch is an optional extra).

ON_RIGS_VARIABLE = "PENDKIT_GRADE_ON_RIGS"  # "queue": judged tests keep their blobs for `judge_on_rigs`
INSTRUCTOR_TEAM = "instructor"  # the team `pendkit queue teams` makes of broker-config's instructor user
FINISHED = ("done", "failed", "cancelled")
AGAIN_LATER = (0, 429, 502, 503)  # a served queue away a moment, or the team's waiting jobs at its cap
RULE_HINT = "the kit's rule: at least 9 of 10 episodes end held within 0.3 rad of upright for their last 200 steps"


def checked_blob(got) -> bytes:
    """The student's return value as a blob the device takes, or `Failed` naming what its checks refuse (the
    queue's own submission checks: the device's parser, a kind it runs, the kit's rig's servo, the size)."""
    from pendkit.queue.jobs import make_job

    if not isinstance(got, (bytes, bytearray)):
        raise Failed(f"deployed_blob() should return the blob's bytes (pack(...)), got {type(got).__name__}")
    try:
        make_job("blob", {}, bytes(got))
    except ConfigError as error:
        raise Failed(str(error)) from None
    return bytes(got)


def judge_blob(blob: bytes) -> str:
    """The feedback of a blob held by the rule on the twin (`Failed` when it is not); with a queue to judge it,
    `Pending` (the rig's verdict comes in `judge_on_rigs`)."""
    if os.environ.get(ON_RIGS_VARIABLE) == "queue":
        raise Pending("waiting for a rig's verdict through the class's queue", blob)
    verdict = twin_verdict(blob)
    said = (f"judged on the twin's device from the rule's starts (no rig queue here: graded with one, a rig judges "
            f"it): {verdict['held']}/{verdict['episodes']} held")
    if verdict["held"] < verdict["needed"]:
        raise Failed(f"{said}, not solved ({RULE_HINT})")
    upright_s = verdict["time_to_upright_s"]
    return f"{said}, solved" + (f"; median time to upright {upright_s:.2f} s" if upright_s is not None else "")


def twin_verdict(blob: bytes) -> dict:
    """The blob on the realistic twin's device (the kit's rig), one episode per start of the rule (`REPORT_SEED`'s
    seeds), judged by the rule. About a second of CPU."""
    import numpy as np

    import pendkit
    from pendkit.agents.policy_rule import REPORT_SEED, RULE_MIN_HELD, RULE_STARTS

    env = pendkit.make(action_mode="continuous", fidelity="realistic", filter_coefficient=0.0)
    held, upright_s = [], []
    try:
        try:
            upload_to_twin(env, blob)
        except DeployError as error:
            raise Failed(f"the twin's device did not take it: {error}") from None
        for k, start in enumerate(RULE_STARTS):
            angles = onboard_episode(env, seed=REPORT_SEED + k, start=start, steps=EPISODE_STEPS)
            held.append(holds_upright(angles, SOLVED_TAIL_STEPS))
            upright_s.append(time_to_upright_s(angles, env.unwrapped.dt))
    finally:
        env.close()
    times = [t for t, ok in zip(upright_s, held) if ok and t is not None]
    return {"held": sum(held), "episodes": len(held), "needed": RULE_MIN_HELD,
            "time_to_upright_s": float(np.median(times)) if times else None}


@dataclass(frozen=True)
class RigQueue:
    """Where `pendkit grade` sends the blobs: a served queue (`server`, the instructor's `token`), or the queue's
    database (`db`, the jobs filed under the instructor's team) that runners serve. `wait_s`: how long to wait
    for the last verdict."""

    server: str | None = None
    db: str | None = None
    token: str | None = field(default=None, repr=False)
    tls_ca: str | None = None
    wait_s: float = 7200.0
    poll_s: float = 2.0

    def __post_init__(self) -> None:
        if (self.server is None) == (self.db is None):
            raise ConfigError("a rig queue is a server (--queue-server) or a database (--queue-db): give one")
        if self.server is not None and not self.token:
            raise ConfigError("no token for the queue: set PENDKIT_QUEUE_TOKEN to the instructor's, or give "
                              "--queue-token-file broker/logins/instructor.txt")
        if not (self.wait_s > 0 and self.poll_s > 0):
            raise ConfigError(f"wait_s and poll_s must be positive, got {self.wait_s}, {self.poll_s}")

    def check_reachable(self) -> None:
        """Before any notebook is graded: the queue answers this token, or its database has the instructor's
        team (`ConfigError`, one line, otherwise)."""
        try:
            queue_jobs = _open(self)
            try:
                queue_jobs.check()
            finally:
                queue_jobs.close()
        except ImportError as error:
            raise ConfigError(f"the queue needs SQLAlchemy ({error.name}): pip install -e \".[queue]\"") from None
        except PendkitError as error:
            raise ConfigError(f"the rig queue at {self.where}: {error}") from None

    @property
    def where(self) -> str:
        if self.server is not None:
            return self.server
        import sqlalchemy as sa

        return sa.engine.make_url(self.db if "://" in self.db else f"sqlite:///{self.db}").render_as_string()


class _Served:
    """Jobs through `pendkit queue serve`, as the instructor's team."""

    def __init__(self, queue: RigQueue) -> None:
        self.client = QueueClient(queue.server, token=queue.token, tls_ca=queue.tls_ca)

    def check(self) -> None:
        self.client.jobs()  # refused (401) for a wrong token

    def submit(self, blob: bytes) -> int:
        return self.client.submit_blob(blob)

    def job(self, job_id: int) -> dict:
        return self.client.job(job_id)

    def close(self) -> None:
        pass


class _Stored:
    """Jobs written to the queue's database directly, as the instructor's team."""

    def __init__(self, queue: RigQueue) -> None:
        from pendkit.queue.store import QueueStore

        self.store = QueueStore(queue.db)

    def check(self) -> None:
        import sqlalchemy as sa

        from pendkit.queue.store import teams

        with self.store.engine.connect() as db:
            if db.execute(sa.select(teams.c.name).where(teams.c.name == INSTRUCTOR_TEAM)).first() is None:
                raise ConfigError(f"it has no team {INSTRUCTOR_TEAM!r} to file the jobs under: run `pendkit queue "
                                  "teams --credentials broker/credentials.csv` first")

    def submit(self, blob: bytes) -> int:
        from pendkit.queue.jobs import submit_job

        return submit_job(self.store, INSTRUCTOR_TEAM, "blob", {}, blob)

    def job(self, job_id: int) -> dict:
        from pendkit.queue.views import job_view

        return job_view(self.store.job(job_id), self.store.result(job_id))

    def close(self) -> None:
        self.store.close()


def _open(queue: RigQueue):
    return _Served(queue) if queue.server is not None else _Stored(queue)


def judge_on_rigs(grades: list, queue: RigQueue, say: Callable[[str], None] | None = None) -> int:
    """Every test of `grades` that waits for a rig: its blob submitted, its verdict turned into its marks (in
    place). Blobs go in as the queue takes them (a served queue holds 10 waiting jobs per team: the rest follow
    as those start). A job that ends without a verdict (failed, cancelled, not run within `queue.wait_s`, refused,
    the queue away) scores 0 with the reason, and a note marked CHECK tells the instructor. The jobs submitted."""
    say = say or (lambda line: print(line, file=sys.stderr))
    backlog = [(grade, task, result) for grade in grades for task in grade.tasks for result in task.results
               if result.pending is not None]
    if not backlog:
        return 0
    try:
        queue_jobs = _open(queue)
    except (PendkitError, ImportError) as error:
        for grade, task, result in backlog:
            result.pending = None
            _not_judged(grade, task, result, f"the queue at {queue.where} could not be opened: {error}")
        return 0
    say(f"{len(backlog)} blobs to judge on the rigs of the queue at {queue.where}, as the instructor's jobs")
    submitted: dict[int, tuple] = {}
    left: set[int] = set()
    deadline, last_problem = time.monotonic() + queue.wait_s, None
    try:
        while backlog or left:
            while backlog:
                grade, task, result = backlog[0]
                try:
                    job_id = queue_jobs.submit(result.pending)
                except PendkitError as error:
                    if getattr(error, "status", None) in AGAIN_LATER:
                        if str(error) != last_problem:
                            say(f"queue: {error}")
                            last_problem = str(error)
                        break
                    backlog.pop(0)
                    result.pending = None
                    _not_judged(grade, task, result, f"the queue did not take it: {error}")
                    continue
                backlog.pop(0)
                result.pending = None
                submitted[job_id] = (grade, task, result)
                left.add(job_id)
                result.message = f"queue job {job_id} was waiting for a rig when grading stopped"
            for job_id in sorted(left):
                try:
                    job = queue_jobs.job(job_id)
                except PendkitError as error:  # the server away a moment: asked again until the deadline
                    if str(error) != last_problem:
                        say(f"queue: {error}")
                        last_problem = str(error)
                    break
                if job["state"] in FINISHED:
                    left.discard(job_id)
                    _mark(*submitted[job_id], job)
                    say(f"job {job_id} ({submitted[job_id][0].student}): {submitted[job_id][2].message}")
            if (not backlog and not left) or time.monotonic() >= deadline:
                break
            time.sleep(queue.poll_s)
    finally:
        queue_jobs.close()
    minutes = f"{queue.wait_s / 60:g} min"
    for job_id in sorted(left):
        _not_judged(*submitted[job_id], f"queue job {job_id} had no verdict after {minutes} (grade again once "
                                        "it has run)")
    for grade, task, result in backlog:
        result.pending = None
        _not_judged(grade, task, result, f"the queue had not taken it after {minutes}")
    return len(submitted)


def _mark(grade, task, result, job: dict) -> None:
    """A finished job's verdict as the test's marks."""
    figures, rig = job.get("figures") or {}, job.get("rig") or "a rig"
    where = f"judged on rig {rig} through the class's queue (job {job['id']})"
    if job["state"] == "done" and figures.get("solved") is not None:
        upright_s = figures.get("time_to_upright_s")
        said = f"{where}, every episode from rest: {figures['verdict']}"
        if figures["solved"]:
            result.points, result.passed = result.max_points, True
            result.message = said + (f"; median time to upright {upright_s:.2f} s" if upright_s is not None else "")
        else:
            result.points, result.passed = 0.0, False
            result.message = f"{said} ({RULE_HINT})"
        return
    reason = job.get("reason") or (job.get("summary") or {}).get("stopped") or "no verdict"
    _not_judged(grade, task, result, f"{where}: {job['state']}, {reason}")


def _not_judged(grade, task, result, reason: str) -> None:
    result.points, result.passed, result.message = 0.0, False, f"not judged on a rig: {reason}"
    grade.notes.append(f"CHECK: {grade.student} {task.task} {result.name}: {reason}; 0 points given")
