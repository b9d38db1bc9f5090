"""Which waiting job a free rig takes: the instructor's first when asked, then the team that has used the least
rig time today among those within their quota (teams past it wait until the others are served), each team's
jobs in the order submitted. Least-used-first is round robin when jobs take the same time, and keeps a team
with long jobs from crowding out the others when they do not."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Waiting:
    """What the choice needs of a waiting job."""

    job_id: int
    team: str
    priority: int  # higher first (the instructor's jobs when asked)
    submitted_at: float
    servo_range: tuple[int, int] | None  # None: any rig


def fits(job: Waiting, rig_servo_range: tuple[int, int] | None) -> bool:
    """A job made for one servo runs only on rigs whose firmware reports that servo's range."""
    return job.servo_range is None or rig_servo_range is None or tuple(job.servo_range) == tuple(rig_servo_range)


def next_job(waiting: list[Waiting], rig_servo_range: tuple[int, int] | None, used_rig_s: dict[str, float],
             quota_rig_s: dict[str, float]) -> Waiting | None:
    """The job the rig takes now, or None when no waiting job fits it. `used_rig_s`: each team's rig seconds
    today (running jobs included); `quota_rig_s`: each team's allowance per day (missing: no limit)."""
    candidates = [job for job in waiting if fits(job, rig_servo_range)]
    if not candidates:
        return None

    def order(job: Waiting):
        used = used_rig_s.get(job.team, 0.0)
        over_quota = used >= quota_rig_s.get(job.team, float("inf"))
        return (-job.priority, over_quota, used, job.submitted_at, job.job_id)

    return min(candidates, key=order)
