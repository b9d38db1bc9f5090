"""What the queue's web face shows, as plain dicts from the store: the public class state (no payloads, no
results, no reasons a team gave), one job as its team sees it, and the leaderboard.

A result's summary is the runner's JSON; these read it leniently (a missing figure shows as none), so the page
keeps working when a runner adds figures: `verdict` (text), `solved`, `held` and `episodes` (a list of one dict
per episode), `time_to_upright_s`, and `pushes` (the twin-with-pushes figure) when the runner measured one."""

from __future__ import annotations

import json
import math
import statistics
import time

import sqlalchemy as sa

from pendkit.checks import is_finite_number
from pendkit.queue.fair import Waiting, next_job
from pendkit.queue.store import Job, QueueStore, jobs, results, teams

FINISHED_SHOWN = 100  # the class page lists every waiting and running job and this many finished ones
TYPICAL_JOB_RIG_S = 120.0
FINISHED = ("done", "failed", "cancelled")  # a job's rig time when placing waiting jobs, before any finished today


def public_state(store: QueueStore, now: float | None = None) -> dict:
    """Every rig's state and every job's id, team, kind, state, rig and place in the queue."""
    now = time.time() if now is None else now
    rigs = [{"rig": row["rig"], "state": row["state"], "reason": row["reason"] or "", "job_id": row["job_id"],
             "servo_range": [row["servo_min"], row["servo_max"]] if row["servo_min"] is not None else None,
             "seen_s_ago": round(max(0.0, now - (row["seen_at"] or 0.0)), 1)} for row in store.rigs()]
    columns = (jobs.c.id, jobs.c.team, jobs.c.kind, jobs.c.state, jobs.c.rig, jobs.c.priority,
               jobs.c.submitted_at, jobs.c.servo_min, jobs.c.servo_max)
    with store.engine.connect() as db:
        open_rows = list(db.execute(sa.select(*columns).where(jobs.c.state.in_(("waiting", "running")))))
        finished_rows = list(db.execute(sa.select(*columns).where(jobs.c.state.in_(FINISHED))
                                        .order_by(jobs.c.id.desc()).limit(FINISHED_SHOWN)))
        quotas = {r.name: r.quota_rig_s for r in db.execute(sa.select(teams.c.name, teams.c.quota_rig_s))
                  if r.quota_rig_s is not None}
        spent = [r.rig_s for r in db.execute(sa.select(jobs.c.rig_s).where(jobs.c.state == "done",
                                                                          jobs.c.rig_s > 0).limit(200))]
    places = queue_places([r for r in open_rows if r.state == "waiting"], store.used_rig_s(now), quotas,
                          statistics.median(spent) if spent else TYPICAL_JOB_RIG_S)
    listed = sorted(open_rows + finished_rows, key=lambda r: r.id)
    return {"rigs": rigs, "jobs": [{"id": r.id, "team": r.team, "kind": r.kind, "state": r.state, "rig": r.rig,
                                    "place": places.get(r.id)} for r in listed]}


def queue_places(waiting_rows, used_rig_s: dict[str, float], quota_rig_s: dict[str, float],
                 job_rig_s: float) -> dict[int, int]:
    """Job id -> 1-based place: the order fair share takes the waiting jobs if each took `job_rig_s` of rig
    time (a rig of another servo may take a later one first)."""
    left = [Waiting(r.id, r.team, r.priority, r.submitted_at,
                    (r.servo_min, r.servo_max) if r.servo_min is not None else None) for r in waiting_rows]
    used = dict(used_rig_s)
    places = {}
    while left:
        chosen = next_job(left, None, used, quota_rig_s)
        places[chosen.job_id] = len(places) + 1
        used[chosen.team] = used.get(chosen.team, 0.0) + job_rig_s
        left.remove(chosen)
    return places


def job_view(job: Job, result: dict | None = None) -> dict:
    """A job as its own team sees it: no payload (its size only); with `result` ({"summary", "telemetry_csv",
    "plot_png"}, the last two as data or as whether there is any), its summary and figures."""
    view = {"id": job.id, "team": job.team, "kind": job.kind, "state": job.state, "rig": job.rig,
            "attempts": job.attempts, "reason": job.reason, "time_limit_s": job.time_limit_s,
            "submitted_at": job.submitted_at, "started_at": job.started_at, "finished_at": job.finished_at,
            "rig_s": round(job.rig_s, 1), "spec": job.spec, "payload_bytes": len(job.payload or b""),
            "servo_range": list(job.servo_range) if job.servo_range else None,
            "summary": None, "figures": None, "telemetry": False, "plot": False}
    if result is not None and job.state in FINISHED:
        view.update(summary=result["summary"], figures=figures(result["summary"]),
                    telemetry=bool(result["telemetry_csv"]), plot=bool(result["plot_png"]))
    return view


def team_jobs(store: QueueStore, team: str) -> list[dict]:
    """A team's jobs with their summaries (not their telemetry or plots, which are fetched one by one)."""
    query = (sa.select(results.c.job_id, results.c.summary,
                       (sa.func.length(results.c.telemetry_csv) > 0).label("telemetry_csv"),
                       results.c.plot_png.is_not(None).label("plot_png"))
             .join(jobs, jobs.c.id == results.c.job_id).where(jobs.c.team == team))
    with store.engine.connect() as db:
        found = {row.job_id: {"summary": json.loads(row.summary), "telemetry_csv": row.telemetry_csv,
                              "plot_png": row.plot_png} for row in db.execute(query)}
    return [job_view(job, found.get(job.id)) for job in store.jobs(team)]


def figures(summary: dict) -> dict | None:
    """The leaderboard's figures of one result, None for a result without a verdict (an excitation)."""
    if not isinstance(summary, dict) or ("verdict" not in summary and "held" not in summary):
        return None
    episodes = summary.get("episodes")
    episodes = episodes if isinstance(episodes, list) else []
    held = summary.get("held")
    if not isinstance(held, int) or isinstance(held, bool):
        held = sum(1 for e in episodes if isinstance(e, dict) and e.get("held") is True)
    asked = _asked(summary.get("verdict"), summary.get("episodes_run", len(episodes)))
    solved = summary.get("solved") if isinstance(summary.get("solved"), bool) else None
    upright_s = _number(summary.get("time_to_upright_s"))
    if upright_s is None:
        times = [_number(e.get("time_to_upright_s")) for e in episodes if isinstance(e, dict) and e.get("held")]
        times = [t for t in times if t is not None]
        upright_s = statistics.median(times) if times else None
    if solved is None:
        verdict = f"{held}/{asked} held (fewer episodes than the rule's: not judged)"
    else:
        verdict = f"{'solved' if solved else 'not solved'}: {held}/{asked} held"
    return {"verdict": verdict, "solved": solved, "held": held, "episodes": asked, "time_to_upright_s": upright_s,
            "pushes": _pushes(summary.get("pushes"))}


def leaderboard(store: QueueStore) -> list[dict]:
    """Each team's best finished job: solved first, then the share of episodes held, then the quicker swing-up."""
    with store.engine.connect() as db:
        rows = list(db.execute(sa.select(jobs.c.id, jobs.c.team, results.c.summary)
                               .join(results, results.c.job_id == jobs.c.id).where(jobs.c.state == "done")))
    best: dict[str, tuple] = {}
    for row in rows:
        try:
            found = figures(json.loads(row.summary))
        except ValueError:
            found = None
        if found is None:
            continue
        key = _rank_key(found)
        if row.team not in best or key > best[row.team][0]:
            best[row.team] = (key, row.id, found)
    ordered = sorted(sorted(best.items()), key=lambda item: item[1][0], reverse=True)  # ties: by team name
    return [{"rank": place, "team": team, "job_id": job_id, **found}
            for place, (team, (_, job_id, found)) in enumerate(ordered, start=1)]


def _rank_key(found: dict) -> tuple:
    share = found["held"] / found["episodes"] if found["episodes"] else 0.0
    upright_s = found["time_to_upright_s"]
    return (found["solved"] is True, share, -upright_s if upright_s is not None else -math.inf)


def _asked(verdict, run) -> int:
    """The episodes a job asked for: N of the runner's "K/N" verdict, else those it ran."""
    if isinstance(verdict, str) and verdict.count("/") == 1:
        asked = verdict.split("/")[1].split()[0] if verdict.split("/")[1].split() else ""
        if asked.isdigit():
            return int(asked)
    return run if isinstance(run, int) and not isinstance(run, bool) else 0


def _number(value) -> float | None:
    if not is_finite_number(value):
        return None
    return float(value)


def _pushes(value) -> str | None:
    """The twin-with-pushes figure as text: the runner's line as it is (while it is judged, or why it was
    skipped), its figures ({"held", "episodes", "solved", ...}) as `K/N held`."""
    if isinstance(value, str):
        return value[:200]
    if isinstance(value, dict) and isinstance(value.get("held"), int) and isinstance(value.get("episodes"), int):
        solved = {True: ", solved", False: ", not solved"}.get(value.get("solved"), "")
        return f"{value['held']}/{value['episodes']} held{solved}"
    return None
