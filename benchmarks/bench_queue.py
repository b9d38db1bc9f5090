"""The queue serving a class: teams' jobs on virtual rigs, a runner killed and a rig killed on the way.

Every team submits its jobs at once (straight into the store through `make_job`, as the server does; the energy
and minimum-time swing-ups in turn, each judged by the kit's rule). Each virtual rig runs in its own process
(`pendkit virtual-rig`, as a rig is its own device) on a Mosquitto broker (the embedded one when Mosquitto is
not installed); one runner process (`pendkit queue run --rig ...`) serves them all. Once a third of the jobs
are done the runner is killed with SIGKILL mid-job and started again at once under its name; once half are done
one rig's process is killed mid-job. The line:

    queue teams=30 jobs=60 rigs=6 busy=F lost=N p95_wait_s=F fair=yes|no

- busy: of the rigs in service (not out, not killed), the share busy with a job (its upload, resets and
  episodes) over the moments at least one job waited, sampled every half second from the first job's start;
  from the runner's kill until its new process starts a job, its rigs count as idle.
- lost: jobs that did not end done with their result, plus results that changed once stored (the twin's
  figure, added after the rig's, aside).
- p95_wait_s: wall seconds from a job's submission to its first start (at --speed 10, a tenth of the rig time).
- fair: every team within its fair share: with N teams and R rigs, a team's j-th job started among the first
  j*N + R starts (strict round robin: no team's next job runs while another team's j-th still waits, up to the
  R jobs the rigs take at once). Least-used-first (`pendkit.queue.fair`) is round robin for jobs alike.

    python benchmarks/bench_queue.py [--teams 30] [--jobs-per-team 2] [--rigs 6] [--speed 10] [--episodes 10]
        [--episode-steps 500] [--no-kills] [--keep DIR]
"""

from __future__ import annotations

import argparse
import json
import secrets
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from pendkit.queue.jobs import submit_job
from pendkit.queue.runner import TWIN_PENDING
from pendkit.queue.store import QueueStore

SAMPLE_S = 0.5
RUNNER = "bench-runner"


def start_broker(folder: Path):
    from pendkit.link.broker import EmbeddedBroker, MosquittoBroker, free_port, mosquitto_binary

    if mosquitto_binary() is not None:
        return MosquittoBroker(folder / "mosquitto").start()
    return EmbeddedBroker(port=free_port()).start()


def rig_process(rig: str, url: str, speed: float) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "pendkit.cli", "virtual-rig", "--rig", rig, "--broker", url,
                             "--speed", str(speed)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def runner_process(db: str, rigs: list[str], url: str, log) -> subprocess.Popen:
    command = [sys.executable, "-m", "pendkit.cli", "queue", "run", "--db", db, "--broker", url, "--name", RUNNER]
    for rig in rigs:
        command += ["--rig", rig]
    return subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT)


def wait_online(rigs: list[str], url: str, timeout_s: float = 60.0) -> None:
    from pendkit.adapt.rigs import rig_status

    deadline = time.monotonic() + timeout_s
    for rig in rigs:
        while rig_status(rig, url, wait_s=0.5).get("online") is not True:
            if time.monotonic() > deadline:
                raise SystemExit(f"virtual rig {rig} did not come up within {timeout_s:g} s")


def lasting(result: dict | None) -> str | None:
    """What of a stored result must never change: all but the twin's figure (added after the rig's)."""
    if result is None:
        return None
    summary = {key: value for key, value in result["summary"].items() if key != "pushes"}
    return json.dumps([summary, result["telemetry_csv"], (result["plot_png"] or b"").hex()])


def fair_share(first_start: dict[int, float], job_team: dict[int, str], teams: int, rigs: int) -> tuple[bool, int]:
    """(every team within its fair share, the largest overshoot in starts): see the module docstring."""
    order = sorted(first_start, key=first_start.get)
    rank = {job_id: k + 1 for k, job_id in enumerate(order)}
    seen: dict[str, int] = {}
    worst = 0
    for job_id in sorted(job_team):  # ids in submission order: a team's j-th job
        team = job_team[job_id]
        seen[team] = seen.get(team, 0) + 1
        if job_id in rank:
            worst = max(worst, rank[job_id] - (seen[team] * teams + rigs))
    return worst <= 0, worst


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--teams", type=int, default=30)
    parser.add_argument("--jobs-per-team", type=int, default=2)
    parser.add_argument("--rigs", type=int, default=6)
    parser.add_argument("--speed", type=float, default=10.0)
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--episode-steps", type=int, default=500)
    parser.add_argument("--no-kills", action="store_true", help="neither the runner nor a rig is killed")
    parser.add_argument("--keep", type=Path, default=None, help="keep the database and the runner's log here")
    args = parser.parse_args()

    folder = Path(tempfile.mkdtemp(prefix="bench-queue-")) if args.keep is None else args.keep
    folder.mkdir(parents=True, exist_ok=True)
    db = f"sqlite:///{folder / 'queue.db'}"
    store = QueueStore(db)
    rig_ids = [f"r{k + 1:02d}" for k in range(args.rigs)]
    team_names = [f"team{k + 1:02d}" for k in range(args.teams)]
    for team in team_names:
        store.add_team(team, secrets.token_hex(16))
    job_team = {}
    for round_index in range(args.jobs_per_team):
        for team in team_names:
            controller = ("energy", "trajopt")[(round_index + team_names.index(team)) % 2]
            job_id = submit_job(store, team, "controller", {"controller": controller, "episodes": args.episodes,
                                                              "episode_steps": args.episode_steps})
            job_team[job_id] = team
    submitted = {job.id: job.submitted_at for job in store.jobs()}

    broker = start_broker(folder)
    rigs = {rig: rig_process(rig, broker.url, args.speed) for rig in rig_ids}
    log = (folder / "runner.log").open("w")
    runner = None
    try:
        wait_online(rig_ids, broker.url)
        runner = runner_process(db, rig_ids, broker.url, log)
        started = time.monotonic()
        runner_dead_until = 0.0  # rigs idle until then: from the kill until the new runner starts a job
        killed_at = 0.0
        killed_runner = killed_rig = args.no_kills
        first_start: dict[int, float] = {}
        kept: dict[int, str] = {}
        busy_samples: list[tuple[int, int]] = []
        changed: set[int] = set()
        total = len(job_team)
        while True:
            jobs = store.jobs()
            rig_rows = {row["rig"]: row for row in store.rigs()}
            for job in jobs:
                if job.state == "running" and job.id not in first_start:
                    first_start[job.id] = job.started_at
                if job.state in ("done", "failed", "cancelled"):
                    now_kept = lasting(store.result(job.id))
                    if job.id in kept and kept[job.id] != now_kept:
                        changed.add(job.id)
                    kept.setdefault(job.id, now_kept)
            finished = sum(job.state in ("done", "failed", "cancelled") for job in jobs)
            waiting = sum(job.state == "waiting" for job in jobs)
            alive = [rig for rig in rig_ids if rigs[rig].poll() is None and rig_rows.get(rig, {}).get("state") != "out"]
            if waiting and alive and first_start:  # from the queue's first job on (not the runner's start-up)
                live = time.monotonic() >= runner_dead_until
                busy = sum(rig_rows.get(rig, {}).get("state") == "busy" for rig in alive) if live else 0
                busy_samples.append((busy, len(alive)))
            if finished == total:
                break
            running = [job for job in jobs if job.state == "running"]
            if not killed_runner and finished >= total // 3 and running:
                runner.send_signal(signal.SIGKILL)
                runner.wait()
                killed_runner = True
                runner_dead_until, killed_at = float("inf"), time.time()
                runner = runner_process(db, rig_ids, broker.url, log)
                print(f"killed the runner mid-job at {time.monotonic() - started:.0f} s ({len(running)} jobs running)")
            if runner_dead_until == float("inf") and any(job.started_at and job.started_at > killed_at for job in jobs):
                runner_dead_until = time.monotonic()  # the new runner runs jobs again
            if not killed_rig and finished >= total // 2 and running:
                victim = running[0].rig
                rigs[victim].send_signal(signal.SIGKILL)
                killed_rig = True
                print(f"killed rig {victim} mid-job at {time.monotonic() - started:.0f} s")
            time.sleep(SAMPLE_S)
        wall_s = time.monotonic() - started
        twin_deadline = time.monotonic() + 120  # the twin's figures follow the rigs' results
        while time.monotonic() < twin_deadline and any(
                store.result(job_id)["summary"].get("pushes") == TWIN_PENDING for job_id in job_team):
            time.sleep(SAMPLE_S)
    finally:
        if runner is not None:
            runner.terminate()
            runner.wait(timeout=60)
        for process in rigs.values():
            if process.poll() is None:
                process.terminate()
                process.wait(timeout=30)
        broker.stop()
        log.close()

    jobs = {job.id: job for job in store.jobs()}
    results = {job_id: store.result(job_id) for job_id in jobs}
    lost = sum(jobs[j].state != "done" or results[j] is None for j in job_team) + len(changed)
    busy = sum(b for b, _ in busy_samples) / max(1, sum(n for _, n in busy_samples))
    waits = [first_start[j] - submitted[j] for j in job_team if j in first_start]
    fair, worst = fair_share(first_start, job_team, args.teams, args.rigs)
    verdicts = [results[j]["summary"].get("verdict") for j in job_team if results[j]]
    solved = sum(bool(results[j]["summary"].get("solved")) for j in job_team if results[j])
    outs = {row["rig"]: row["reason"] for row in store.rigs() if row["state"] == "out"}
    pushes = [results[j]["summary"].get("pushes") for j in job_team if results[j]]
    twin = sum(isinstance(p, dict) and bool(p.get("solved")) for p in pushes)
    failed = sum(job.state == "failed" for job in jobs.values())
    reruns = sum(job.attempts - 1 for job in jobs.values())
    print(f"wall {wall_s:.0f} s; {solved} of {len(verdicts)} jobs solved by the rule on the rigs, {twin} on the twin "
          f"with pushes ({sum(isinstance(p, dict) for p in pushes)} judged there); failed {failed}; reruns {reruns}; "
          f"fair overshoot {worst} starts; out of service: {outs or 'none'}")
    print(f"queue teams={args.teams} jobs={len(job_team)} rigs={args.rigs} busy={busy:.2f} lost={lost} "
          f"p95_wait_s={np.percentile(waits, 95):.1f} fair={'yes' if fair else 'no'}")
    store.close()
    if args.keep is None:
        import shutil

        shutil.rmtree(folder, ignore_errors=True)
    else:
        print(f"database and runner log in {folder}")


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py (here: tests load this file alone)

    print_header()
    main()
