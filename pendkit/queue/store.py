"""The queue's state in a database (SQLAlchemy Core): teams, rigs, jobs and their results. An SQLite file by
default (`sqlite:///queue.db`: nothing to install), PostgreSQL by URL (`postgresql+psycopg://...`) when runners
on several machines share one queue.

A job is claimed by a conditional update (`state='waiting'` to `'running'`): two runners asking at once
cannot both take it, on either database, without locks held across the network. Every change is one
transaction, so a queue or runner killed at any moment leaves each job waiting, running (given back by
`requeue_running` or `requeue_stale`) or finished with its result."""

from __future__ import annotations

import hashlib
import json
import sqlite3
import time
from dataclasses import dataclass
from datetime import datetime, timezone

import sqlalchemy as sa

from pendkit.errors import ConfigError
from pendkit.queue.fair import Waiting, next_job

JOB_STATES = ("waiting", "running", "done", "failed", "cancelled")
RIG_STATES = ("free", "busy", "out")  # out: out of service, with the reason
MAX_ATTEMPTS = 3  # a job that loses its rig this often fails, with the reasons

metadata = sa.MetaData()
teams = sa.Table(
    "teams", metadata,
    sa.Column("name", sa.String(64), primary_key=True),
    sa.Column("token_sha256", sa.String(64), nullable=False, unique=True),
    sa.Column("quota_rig_s", sa.Float, nullable=True),  # per day; None: no limit
    sa.Column("instructor", sa.Boolean, nullable=False, default=False),
)
rigs = sa.Table(
    "rigs", metadata,
    sa.Column("rig", sa.String(64), primary_key=True),
    sa.Column("servo_min", sa.Integer), sa.Column("servo_max", sa.Integer),
    sa.Column("runner", sa.String(128)),
    sa.Column("state", sa.String(8), nullable=False, default="free"),
    sa.Column("reason", sa.Text, default=""),
    sa.Column("job_id", sa.Integer, nullable=True),
    sa.Column("seen_at", sa.Float, nullable=False, default=0.0),
)
jobs = sa.Table(
    "jobs", metadata,
    sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
    sa.Column("team", sa.String(64), sa.ForeignKey("teams.name"), nullable=False),
    sa.Column("kind", sa.String(16), nullable=False),
    sa.Column("spec", sa.Text, nullable=False),  # JSON: what to run and how
    sa.Column("payload", sa.LargeBinary, nullable=True),  # a blob or a run's weights
    sa.Column("servo_min", sa.Integer), sa.Column("servo_max", sa.Integer),
    sa.Column("priority", sa.Integer, nullable=False, default=0),
    sa.Column("state", sa.String(10), nullable=False, default="waiting"),
    sa.Column("rig", sa.String(64)), sa.Column("runner", sa.String(128)),
    sa.Column("attempts", sa.Integer, nullable=False, default=0),
    sa.Column("reason", sa.Text, default=""),
    sa.Column("time_limit_s", sa.Float, nullable=False),
    sa.Column("submitted_at", sa.Float, nullable=False),
    sa.Column("started_at", sa.Float), sa.Column("finished_at", sa.Float),
    sa.Column("rig_s", sa.Float, nullable=False, default=0.0),  # rig time spent, all attempts
)
results = sa.Table(
    "results", metadata,
    sa.Column("job_id", sa.Integer, sa.ForeignKey("jobs.id"), primary_key=True),
    sa.Column("summary", sa.Text, nullable=False),  # JSON: verdict, episodes, times to upright, ...
    sa.Column("telemetry_csv", sa.Text, nullable=False, default=""),
    sa.Column("plot_png", sa.LargeBinary, nullable=True),
)


def token_digest(token: str) -> str:
    return hashlib.sha256(token.encode()).hexdigest()


def day_start(now: float) -> float:
    """Midnight UTC of `now`'s day: quotas count rig time since then."""
    moment = datetime.fromtimestamp(now, tz=timezone.utc)
    return moment.replace(hour=0, minute=0, second=0, microsecond=0).timestamp()


@dataclass(frozen=True)
class Job:
    id: int
    team: str
    kind: str
    spec: dict
    payload: bytes | None
    servo_range: tuple[int, int] | None
    state: str
    rig: str | None
    attempts: int
    reason: str
    time_limit_s: float
    submitted_at: float
    started_at: float | None
    finished_at: float | None
    rig_s: float

    @classmethod
    def from_row(cls, row) -> Job:
        servo = (row.servo_min, row.servo_max) if row.servo_min is not None else None
        return cls(row.id, row.team, row.kind, json.loads(row.spec), row.payload, servo, row.state, row.rig,
                   row.attempts, row.reason or "", row.time_limit_s, row.submitted_at, row.started_at,
                   row.finished_at, row.rig_s)


class QueueStore:
    """The queue's tables behind one engine. `url`: an SQLAlchemy URL, or a path for an SQLite file."""

    def __init__(self, url: str) -> None:
        if "://" not in url:
            url = f"sqlite:///{url}"
        self.url = url
        try:
            self.engine = sa.create_engine(url, **_engine_options(url))
            if url.startswith("sqlite"):
                sa.event.listen(self.engine, "connect", _sqlite_shared)
            _create_tables(self.engine)
        except (sa.exc.ArgumentError, sa.exc.NoSuchModuleError) as error:
            raise ConfigError(f"queue database {url!r}: {error}") from None
        except sa.exc.OperationalError as error:
            raise ConfigError(f"cannot open the queue database {sa.engine.make_url(url).render_as_string()}: "
                              f"{str(error.orig).strip().splitlines()[0]}") from None

    def close(self) -> None:
        self.engine.dispose()

    # --- teams ---
    def add_team(self, name: str, token: str, quota_rig_s: float | None = None, instructor: bool = False) -> None:
        """Add a team (or give it a new token and quota)."""
        values = {"token_sha256": token_digest(token), "quota_rig_s": quota_rig_s, "instructor": instructor}
        with self.engine.begin() as db:
            if db.execute(sa.select(teams.c.name).where(teams.c.name == name)).first():
                db.execute(teams.update().where(teams.c.name == name).values(**values))
            else:
                db.execute(teams.insert().values(name=name, **values))

    def team_for_token(self, token: str) -> tuple[str, bool] | None:
        """(team, is the instructor) for a token, None for an unknown one."""
        with self.engine.connect() as db:
            row = db.execute(sa.select(teams.c.name, teams.c.instructor)
                             .where(teams.c.token_sha256 == token_digest(token))).first()
        return (row.name, bool(row.instructor)) if row else None

    # --- jobs ---
    def submit(self, team: str, kind: str, spec: dict, payload: bytes | None = None,
               servo_range: tuple[int, int] | None = None, priority: int = 0, time_limit_s: float = 600.0) -> int:
        """Queue a job; its id."""
        servo = servo_range or (None, None)
        with self.engine.begin() as db:
            # checked here, not left to the foreign key: SQLite does not enforce it unless asked, PostgreSQL does
            if db.execute(sa.select(teams.c.name).where(teams.c.name == team)).first() is None:
                raise ConfigError(f"unknown team {team!r}: add it with `pendkit queue teams`")
            result = db.execute(jobs.insert().values(
                team=team, kind=kind, spec=json.dumps(spec), payload=payload, servo_min=servo[0],
                servo_max=servo[1], priority=priority, state="waiting", attempts=0, reason="",
                time_limit_s=time_limit_s, submitted_at=time.time(), rig_s=0.0))
            return int(result.inserted_primary_key[0])

    def job(self, job_id: int, team: str | None = None) -> Job | None:
        """A job, if it exists and (given `team`) belongs to that team."""
        query = sa.select(jobs).where(jobs.c.id == job_id)
        if team is not None:
            query = query.where(jobs.c.team == team)
        with self.engine.connect() as db:
            row = db.execute(query).first()
        return Job.from_row(row) if row else None

    def jobs(self, team: str | None = None, states: tuple[str, ...] = JOB_STATES) -> list[Job]:
        query = sa.select(jobs).where(jobs.c.state.in_(states)).order_by(jobs.c.id)
        if team is not None:
            query = query.where(jobs.c.team == team)
        with self.engine.connect() as db:
            return [Job.from_row(row) for row in db.execute(query)]

    def cancel(self, job_id: int, team: str | None = None) -> bool:
        """Cancel a waiting or running job (a runner sees it at its next check and stops the rig)."""
        query = jobs.update().where(jobs.c.id == job_id, jobs.c.state.in_(("waiting", "running")))
        if team is not None:
            query = query.where(jobs.c.team == team)
        with self.engine.begin() as db:
            return db.execute(query.values(state="cancelled", finished_at=time.time(),
                                           reason="cancelled")).rowcount == 1

    def used_rig_s(self, now: float | None = None) -> dict[str, float]:
        """Each team's rig seconds today: finished jobs' and the running ones' so far."""
        now = time.time() if now is None else now
        since = day_start(now)
        used: dict[str, float] = {}
        with self.engine.connect() as db:
            for row in db.execute(sa.select(jobs.c.team, jobs.c.state, jobs.c.rig_s, jobs.c.started_at)
                                  .where(sa.or_(jobs.c.finished_at >= since, jobs.c.state == "running"))):
                running = now - row.started_at if row.state == "running" and row.started_at else 0.0
                used[row.team] = used.get(row.team, 0.0) + row.rig_s + running
        return used

    def claim(self, rig: str, runner: str, attempts: int = 5) -> Job | None:
        """The job this free rig runs next (fair share, its servo), marked running on it; None when none waits."""
        for _ in range(attempts):
            with self.engine.connect() as db:
                rig_row = db.execute(sa.select(rigs).where(rigs.c.rig == rig)).first()
                waiting = [Waiting(r.id, r.team, r.priority, r.submitted_at,
                                   (r.servo_min, r.servo_max) if r.servo_min is not None else None)
                           for r in db.execute(sa.select(jobs.c.id, jobs.c.team, jobs.c.priority, jobs.c.submitted_at,
                                                         jobs.c.servo_min, jobs.c.servo_max)
                                               .where(jobs.c.state == "waiting"))]
                quotas = {r.name: r.quota_rig_s for r in db.execute(sa.select(teams.c.name, teams.c.quota_rig_s))
                          if r.quota_rig_s is not None}
            if rig_row is None or rig_row.state != "free":
                return None  # unknown, busy with a job, or out of service
            servo = (rig_row.servo_min, rig_row.servo_max) if rig_row.servo_min is not None else None
            chosen = next_job(waiting, servo, self.used_rig_s(), quotas)
            if chosen is None:
                return None
            now = time.time()
            with self.engine.begin() as db:
                taken = db.execute(jobs.update().where(jobs.c.id == chosen.job_id, jobs.c.state == "waiting")
                                   .values(state="running", rig=rig, runner=runner, started_at=now,
                                           attempts=jobs.c.attempts + 1)).rowcount
                if taken:
                    db.execute(rigs.update().where(rigs.c.rig == rig)
                               .values(state="busy", job_id=chosen.job_id, seen_at=now))
                    return Job.from_row(db.execute(sa.select(jobs).where(jobs.c.id == chosen.job_id)).first())
        return None

    def finish(self, job_id: int, summary: dict, telemetry_csv: str = "", plot_png: bytes | None = None,
               failed: bool = False, reason: str = "") -> bool:
        """Store a running job's result and free its rig; False if the job was cancelled meanwhile (the result
        is kept all the same)."""
        now = time.time()
        with self.engine.begin() as db:
            row = db.execute(sa.select(jobs.c.state, jobs.c.started_at, jobs.c.rig).where(jobs.c.id == job_id)).first()
            if row is None:
                return False
            spent = now - row.started_at if row.started_at else 0.0
            db.execute(results.delete().where(results.c.job_id == job_id))
            db.execute(results.insert().values(job_id=job_id, summary=json.dumps(summary),
                                               telemetry_csv=telemetry_csv, plot_png=plot_png))
            finished = row.state == "running"
            if finished:
                db.execute(jobs.update().where(jobs.c.id == job_id).values(
                    state="failed" if failed else "done", finished_at=now, reason=reason,
                    rig_s=jobs.c.rig_s + spent))
            db.execute(rigs.update().where(rigs.c.job_id == job_id, rigs.c.state == "busy")
                       .values(state="free", job_id=None, seen_at=now))
            return finished

    def requeue(self, job_id: int, reason: str) -> str:
        """A running job that lost its rig goes back to waiting (the rig time spent is counted), or fails after
        MAX_ATTEMPTS; the new state."""
        now = time.time()
        with self.engine.begin() as db:
            row = db.execute(sa.select(jobs.c.state, jobs.c.attempts, jobs.c.started_at, jobs.c.reason)
                             .where(jobs.c.id == job_id)).first()
            if row is None or row.state != "running":
                return row.state if row else "missing"
            state = "failed" if row.attempts >= MAX_ATTEMPTS else "waiting"
            reasons = "; ".join(part for part in (row.reason, reason) if part)
            db.execute(jobs.update().where(jobs.c.id == job_id).values(
                state=state, rig=None, runner=None, reason=reasons[-2000:],
                finished_at=now if state == "failed" else None,
                rig_s=jobs.c.rig_s + (now - row.started_at if row.started_at else 0.0)))
            db.execute(rigs.update().where(rigs.c.job_id == job_id).values(job_id=None))
            return state

    def requeue_running(self, runner: str, reason: str = "the runner restarted") -> int:
        """On a runner's start: its jobs left running go back to waiting; how many."""
        with self.engine.connect() as db:
            ids = [r.id for r in db.execute(sa.select(jobs.c.id).where(jobs.c.state == "running",
                                                                      jobs.c.runner == runner))]
        for job_id in ids:
            self.requeue(job_id, reason)
        with self.engine.begin() as db:
            db.execute(rigs.update().where(rigs.c.runner == runner, rigs.c.state == "busy")
                       .values(state="free", job_id=None))
        return len(ids)

    def requeue_stale(self, max_age_s: float) -> int:
        """Jobs on rigs whose runner has not been heard from for `max_age_s` (it died) go back to waiting."""
        cutoff = time.time() - max_age_s
        with self.engine.connect() as db:
            ids = [r.job_id for r in db.execute(sa.select(rigs.c.job_id).where(rigs.c.state == "busy",
                                                                             rigs.c.seen_at < cutoff))]
        for job_id in ids:
            self.requeue(job_id, "its runner stopped answering")
        return len(ids)

    def result(self, job_id: int) -> dict | None:
        """{"summary", "telemetry_csv", "plot_png"} of a job, if it has one."""
        with self.engine.connect() as db:
            row = db.execute(sa.select(results).where(results.c.job_id == job_id)).first()
        return None if row is None else {"summary": json.loads(row.summary), "telemetry_csv": row.telemetry_csv,
                                         "plot_png": row.plot_png}

    # --- rigs ---
    def register_rig(self, rig: str, runner: str, servo_range: tuple[int, int] | None) -> None:
        """A runner serves this rig (again): free, unless it was taken out of service."""
        servo = servo_range or (None, None)
        now = time.time()
        with self.engine.begin() as db:
            row = db.execute(sa.select(rigs.c.state).where(rigs.c.rig == rig)).first()
            values = {"runner": runner, "servo_min": servo[0], "servo_max": servo[1], "seen_at": now}
            if row is None:
                db.execute(rigs.insert().values(rig=rig, state="free", reason="", job_id=None, **values))
            else:
                db.execute(rigs.update().where(rigs.c.rig == rig).values(**values))

    def heartbeat(self, rig: str) -> None:
        with self.engine.begin() as db:
            db.execute(rigs.update().where(rigs.c.rig == rig).values(seen_at=time.time()))

    def take_out(self, rig: str, reason: str) -> None:
        """Out of service with the reason (the instructor puts it back with `put_back`)."""
        with self.engine.begin() as db:
            db.execute(rigs.update().where(rigs.c.rig == rig).values(state="out", reason=reason[:2000],
                                                                      job_id=None))

    def put_back(self, rig: str) -> bool:
        with self.engine.begin() as db:
            return db.execute(rigs.update().where(rigs.c.rig == rig, rigs.c.state == "out")
                              .values(state="free", reason="")).rowcount == 1

    def rigs(self) -> list[dict]:
        with self.engine.connect() as db:
            return [dict(row._mapping) for row in db.execute(sa.select(rigs).order_by(rigs.c.rig))]


TABLES_LOCK = 690069  # PostgreSQL advisory lock key held while the tables are created
WAL_ATTEMPTS = 100  # 5 s


def _create_tables(engine: sa.Engine) -> None:
    """Create the missing tables. Runners started together on a fresh database would otherwise both see a
    table missing and the second fail creating it ("already exists"): one creates them while the others wait."""
    with engine.connect() as db:
        if engine.dialect.name == "postgresql":
            db.execute(sa.text("SELECT pg_advisory_xact_lock(:key)"), {"key": TABLES_LOCK})
        elif engine.dialect.name == "sqlite":
            db.exec_driver_sql("BEGIN IMMEDIATE")  # the file's write lock, waited for up to its timeout
        metadata.create_all(db)
        db.commit()


def _engine_options(url: str) -> dict:
    if url.startswith("sqlite"):
        # several processes share the file: wait for a writer rather than fail at once
        return {"connect_args": {"timeout": 30}}
    return {"pool_pre_ping": True}


def _sqlite_shared(dbapi_connection, connection_record) -> None:
    """Write-ahead logging: the class page reads while a runner writes. Switching a fresh file to it while
    another process opens it can fail at once with "database is locked" (SQLite skips the busy wait where
    waiting could deadlock): tried again for a few seconds."""
    for attempt in range(WAL_ATTEMPTS):
        try:
            dbapi_connection.execute("PRAGMA journal_mode=WAL")
            return
        except sqlite3.OperationalError as error:
            if "locked" not in str(error) or attempt == WAL_ATTEMPTS - 1:
                raise
            time.sleep(0.05)
