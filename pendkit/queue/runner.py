"""A runner: serves one or several rigs from the queue, one thread per rig.

Each rig is registered with the servo range its status reports; then, over and over: heartbeat, give back the
jobs of runners that stopped answering (`requeue_stale`), `claim` a job, run it. A judged job uploads its blob
(the device refuses a bad one) and runs its episodes, each after the unattended reset
(`pendkit.queue.rig_reset`); its cancel and time limit are watched every control step (the store is read every
`CHECK_EVERY_S`), and at its end the controller stops (`k0`) and the servo holds. The result (summary, telemetry,
plot) is stored with `finish`; the same blob on the twin with pushes is judged in a thread of its own, so the rig
takes its next job meanwhile. A rig that goes silent or offline, does not settle or reports a stuck encoder is
taken out of service with the reason and its job goes back to waiting for another rig. A runner started again
gives back the jobs it left running (`requeue_running`).
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import sqlalchemy as sa

from pendkit.deploy.on_rig import RigSession, controller_status, stop, upload_to_rig
from pendkit.deploy.on_twin import DeployError
from pendkit.deploy.swingup_design import design_swing_up
from pendkit.device.controller_blob import pack
from pendkit.link.rig_backend import is_servo_counts_range
from pendkit.queue import job_results
from pendkit.queue import store as tables
from pendkit.queue.fair import Waiting, fits
from pendkit.queue.rig_episodes import Sample, device_episode, watchdog_command
from pendkit.queue.rig_reset import JobCancelled, JobStopped, RigFault, RigWatch, RunnerStopping
from pendkit.rig import RigParams

LOG = logging.getLogger("pendkit.queue")
POLL_S = 0.2  # an idle rig asks for a job this often (wall seconds)
CHECK_EVERY_S = 0.5  # the rigs' heartbeats and the running jobs' cancels go to and come from the store this often
STALE_AFTER_S = 30.0  # a busy rig not heard from this long: its runner died, its job goes back
STALE_CHECK_EVERY_S = 5.0
SPEED_RANGE = (0.1, 100.0)  # a virtual rig's time per wall second, as its status reports it
TWIN_PENDING = "being judged on the twin"  # a result's twin figure until it is there


@dataclass
class ServedRig:
    """One rig of this runner: its link and session, what its status reported, its speed."""

    name: str
    session: RigSession
    servo_range: tuple[int, int] | None = None
    speed: float = 1.0

    @property
    def params(self) -> RigParams:
        """The kit's rig with the servo range this rig's firmware reports (as `pendkit adapt`'s prior)."""
        if self.servo_range is None:
            return RigParams()
        return dataclasses.replace(RigParams(), servo_min_counts=self.servo_range[0],
                                   servo_max_counts=self.servo_range[1])


class JobWatch:
    """Called every control step of a job: raises when it must end (cancelled, time limit, runner stopping).
    Reads memory only: the runner's watch thread reads the store (a database that stalls must not stall the
    heartbeats a rig's watchdog waits for)."""

    def __init__(self, job, rig: ServedRig, stopping: threading.Event) -> None:
        self.job, self.rig, self.stopping = job, rig, stopping
        self.deadline = time.monotonic() + job.time_limit_s / rig.speed
        self.cancelled = threading.Event()

    def __call__(self) -> None:
        if self.stopping.is_set():
            raise RunnerStopping("the runner stopped")
        if self.cancelled.is_set():
            raise JobCancelled("cancelled")
        if time.monotonic() >= self.deadline:
            raise JobStopped(f"its time limit ran out ({self.job.time_limit_s:g} s of the rig's time): stopped, "
                             "the servo holds")


class QueueRunner:
    """Serves `links` (a `RigLink` per rig) from `store` as `runner_name`. `speed`: the rigs' time per wall
    second when their status does not say (a virtual rig's does); `twin_pushes`: also judge each blob on the
    twin with pushes; `say`: progress lines; `excitation`: what records an excitation job
    (`pendkit.adapt.queued.record_excitation`, above the queue's layer: `pendkit queue run` passes it)."""

    def __init__(self, store, links: list, runner_name: str, speed: float = 1.0,
                 say: Callable[[str], None] = print, twin_pushes: bool = True,
                 stale_after_s: float = STALE_AFTER_S, excitation: Callable | None = None) -> None:
        self.store, self.name, self.speed, self.say = store, runner_name, speed, say
        self.excitation = excitation
        self.rigs = [ServedRig(link.rig, RigSession(link)) for link in links]
        self.twin_pushes, self.stale_after_s = twin_pushes, stale_after_s
        self.stopping = threading.Event()
        self._threads: list[threading.Thread] = []
        self._twin_jobs: queue.Queue = queue.Queue()
        self._watches: dict[int, JobWatch] = {}  # the running jobs
        self._next_stale_check = 0.0

    # --- life cycle ---
    def start(self) -> QueueRunner:
        given_back = self.store.requeue_running(self.name)
        if given_back:
            self.say(f"runner {self.name}: {given_back} job(s) it left running went back to waiting")
        _warm_up(self.twin_pushes)
        for rig in self.rigs:
            if not rig.session.link.connected:
                rig.session.link.connect()
            self._register(rig)
        if self.twin_pushes:  # the twin's figures a runner killed before it judged them
            for job_id in _awaiting_twin(self.store):
                job = self.store.job(job_id)
                self._twin_jobs.put((job.id, job.payload, job.spec))
        self._threads = [threading.Thread(target=self._serve, args=(rig,), daemon=True, name=f"queue-{rig.name}")
                         for rig in self.rigs]
        self._threads.append(threading.Thread(target=self._judge_on_twin, daemon=True, name="queue-twin"))
        self._threads.append(threading.Thread(target=self._watch_store, daemon=True, name="queue-watch"))
        for thread in self._threads:
            thread.start()
        return self

    def run(self, once: bool = False) -> None:
        """Serve until `stop()` (or Ctrl-C); `once`: until no job is left that these rigs could run."""
        self.start()
        try:
            while not self.stopping.wait(POLL_S):
                if once and self.idle():
                    break
        finally:
            self.stop()

    def stop(self) -> None:
        """Stop taking jobs; a running job goes back to waiting, its rig's controller stopped."""
        self.stopping.set()
        self._twin_jobs.put(None)
        for thread in self._threads:
            thread.join(timeout=30)

    def idle(self) -> bool:
        """Nothing running here, no twin judging pending, no waiting job that a rig in service here fits."""
        if self._watches or self._twin_jobs.unfinished_tasks:
            return False
        mine = {rig.name for rig in self.rigs}
        if any(job.rig in mine for job in self.store.jobs(states=("running",))):
            return False  # claimed a moment ago, not yet started
        states = {row["rig"]: row["state"] for row in self.store.rigs()}
        serving = [rig.servo_range for rig in self.rigs if states.get(rig.name) != "out"]

        for job in self.store.jobs(states=("waiting",)):
            waiting = Waiting(job.id, job.team, 0, job.submitted_at, job.servo_range)
            if any(fits(waiting, servo) for servo in serving):
                return False
        return True

    # --- one rig ---
    def _register(self, rig: ServedRig) -> None:
        status = rig.session.status()
        counts = status.get("servo_counts_range")
        rig.servo_range = tuple(counts) if is_servo_counts_range(counts) else None
        speed = status.get("speed")
        valid = isinstance(speed, (int, float)) and not isinstance(speed, bool) and math.isfinite(speed) \
            and SPEED_RANGE[0] <= speed <= SPEED_RANGE[1]
        rig.speed = float(speed) if valid else self.speed
        self.store.register_rig(rig.name, self.name, rig.servo_range)
        _release_rig(self.store, rig.name)  # a busy mark left by a runner that died
        if not status:
            reason = f"silent when runner {self.name} started: {rig.session.link.why_silent()}"
            self.store.take_out(rig.name, reason)
            self.say(f"{rig.name}: out of service: {reason}")
            return
        if rig.speed > 1:
            # a virtual rig K times faster than real time: its watchdog K times longer in its own time, the same
            # wall time a real rig's gives this host (a busy machine's pause must not drop the pendulum)
            rig.session.command(watchdog_command(rig.params.watchdog_timeout_ms / 1000.0, rig.speed))
        servo = "?" if rig.servo_range is None else f"{rig.servo_range[0]}..{rig.servo_range[1]}"
        self.say(f"{rig.name}: serving (servo {servo} counts, {rig.speed:g}x)")

    def _serve(self, rig: ServedRig) -> None:
        health = RigWatch(rig.session.link, rig.speed)
        while not self.stopping.is_set():
            try:
                problem = health.problem()
                if problem is not None:  # gone while idle: out before it takes a job (and costs it an attempt)
                    if self._state_of(rig.name) != "out":
                        self.store.take_out(rig.name, problem)
                        self.say(f"{rig.name}: out of service: {problem}")
                    job = None
                else:
                    job = self.store.claim(rig.name, self.name)
            except sa.exc.SQLAlchemyError as error:  # a database that is busy or away a moment: try again
                LOG.warning("queue store: %s", str(error).splitlines()[0])
                job = None
            if job is None:
                self.stopping.wait(POLL_S)
                continue
            self._watches[job.id] = watch = JobWatch(job, rig, self.stopping)
            try:
                self._run_job(rig, job, watch)
            finally:
                self._watches.pop(job.id, None)

    def _state_of(self, rig: str) -> str | None:
        return next((row["state"] for row in self.store.rigs() if row["rig"] == rig), None)

    def _watch_store(self) -> None:
        """Every CHECK_EVERY_S: each rig's heartbeat, each running job's cancel, the stale runners' jobs given
        back (STALE_CHECK_EVERY_S)."""
        while not self.stopping.wait(CHECK_EVERY_S):
            try:
                for rig in self.rigs:
                    self.store.heartbeat(rig.name)
                for job_id, watch in list(self._watches.items()):
                    current = self.store.job(job_id)
                    if current is None or current.state == "cancelled":
                        watch.cancelled.set()
                now = time.monotonic()
                if now >= self._next_stale_check:
                    self._next_stale_check = now + STALE_CHECK_EVERY_S
                    given_back = self.store.requeue_stale(self.stale_after_s)
                    if given_back:
                        self.say(f"{given_back} job(s) of a runner that stopped answering went back to waiting")
            except sa.exc.SQLAlchemyError as error:
                LOG.warning("queue store: %s", str(error).splitlines()[0])

    def _run_job(self, rig: ServedRig, job, watch: JobWatch) -> None:
        self.say(f"{rig.name}: job {job.id} ({job.team}, {job.kind}) started, attempt {job.attempts}")
        runs: list[list] = []
        summary: dict = {"kind": job.kind, "rig": rig.name, "runner": self.name, "attempt": job.attempts,
                         "episode_steps": job.spec.get("episode_steps"), "control_step_s": job.spec["control_step_s"],
                         "reset_s": []}
        if job.reason:  # why earlier attempts lost their rigs
            summary["earlier_attempts"] = job.reason
        try:
            try:
                if job.kind == "excitation":
                    self._excitation(rig, job, watch, runs, summary)
                else:
                    self._judged(rig, job, watch, runs, summary)
            finally:
                stop(rig.session, attempts=2)  # k0, the servo holds
        except RigFault as fault:
            self.store.take_out(rig.name, str(fault))
            state = self.store.requeue(job.id, str(fault))
            self.say(f"{rig.name}: out of service: {fault}; job {job.id} is {state}")
        except RunnerStopping:
            self.store.requeue(job.id, "its runner stopped")
            _release_rig(self.store, rig.name)
            self.say(f"{rig.name}: job {job.id} went back to waiting (the runner stopped)")
        except (JobCancelled, JobStopped) as ended:
            summary["stopped"] = str(ended)
            failed = isinstance(ended, JobStopped)
            self._finish(job, rig, runs, summary, failed=failed, reason=str(ended) if failed else "")
        except Exception as error:  # a bug here must not stop the rig's thread, nor leave the job running
            LOG.exception("job %s on %s failed", job.id, rig.name)
            summary["stopped"] = f"the runner failed: {type(error).__name__}: {error}"
            self._finish(job, rig, runs, summary, failed=True, reason=summary["stopped"])
        else:
            self._finish(job, rig, runs, summary)

    def _judged(self, rig: ServedRig, job, watch: JobWatch, runs: list, summary: dict) -> None:
        spec, session = job.spec, rig.session
        status = session.status()
        if not status:
            raise RigFault(f"rig {rig.name} is silent: {session.link.why_silent()}")
        live = status.get("servo_counts_range")
        if job.servo_range is not None and list(live or []) != list(job.servo_range):
            raise RigFault(f"rig {rig.name} now reports servo counts {live}, not the {rig.servo_range} it was "
                           "registered with (reflashed?): restart its runner")
        try:
            refused_before = controller_status(session)["refused"]
            upload_to_rig(session, job.payload)
        except DeployError as error:
            try:
                after = controller_status(session)
            except DeployError:
                raise RigFault(str(error)) from None
            if after["refused"] > refused_before:
                raise JobStopped(f"the rig refused the blob: {after['last_refusal']}") from None
            raise RigFault(str(error)) from None
        summary.update(job_results.judged_summary([], spec["episodes"], spec["control_step_s"]))
        for _ in range(spec["episodes"]):
            samples: list = []
            runs.append(samples)
            try:
                summary["reset_s"].append(round(device_episode(session, rig.params, spec["episode_steps"],
                                                               spec["control_step_s"], rig.speed, watch, samples), 1))
            finally:
                summary.update(job_results.judged_summary(runs, spec["episodes"], spec["control_step_s"]))

    def _excitation(self, rig: ServedRig, job, watch: JobWatch, runs: list, summary: dict) -> None:
        if self.excitation is None:
            raise JobStopped("this runner records no excitation: start it with `pendkit queue run`")
        recordings: list = []
        try:
            self.excitation(rig.session, rig.params, rig.speed, job.spec, watch, runs, recordings)
        finally:
            summary.update(job_results.excitation_summary(recordings, rig.servo_range))

    def _finish(self, job, rig: ServedRig, runs: list, summary: dict, failed: bool = False, reason: str = "") -> None:
        held = [episode["held"] for episode in summary.get("episodes", []) if isinstance(episode, dict)]
        title = (f"job {job.id} ({job.team}) on {rig.name}: " +
                 (f"{summary['verdict']} held" if "verdict" in summary else f"{len(runs)} excitation episodes"))
        png = job_results.plot_png(runs, title, held if job.kind != "excitation" else None) if runs else None
        judged_twin = self.twin_pushes and job.kind != "excitation" and not failed and "verdict" in summary
        if "verdict" in summary:
            summary["pushes"] = (TWIN_PENDING if judged_twin
                                 else "not judged on the twin" + ("" if self.twin_pushes else " (--no-twin)"))
        finished = self.store.finish(job.id, summary, job_results.telemetry_csv(runs), png, failed,
                                     reason if failed else job.reason)  # a job that ran twice keeps why
        shown = summary.get("verdict", f"{len(runs)} episodes recorded")
        self.say(f"{rig.name}: job {job.id} " + ("failed: " + reason if failed else
                                                 f"done: {shown}" if finished else f"cancelled ({shown} so far)"))
        if judged_twin and finished:
            self._twin_jobs.put((job.id, job.payload, job.spec))

    def _judge_on_twin(self) -> None:
        """The leaderboard's twin column, one job at a time, off the rigs' threads."""
        while True:
            item = self._twin_jobs.get()
            try:
                if item is None:
                    return
                job_id, blob, spec = item
                try:
                    pushes = job_results.twin_with_pushes(blob, spec["params"], spec["episodes"],
                                                          spec["episode_steps"], spec["control_step_s"])
                except Exception as error:  # the rig's result stands whatever the twin does
                    LOG.exception("twin judging of job %s failed", job_id)
                    pushes = f"not judged on the twin: {type(error).__name__}: {error}"[:200]
                _merge_summary(self.store, job_id, {"pushes": pushes})
            finally:
                self._twin_jobs.task_done()


def _warm_up(twin: bool) -> None:
    """Draw a plot (and run the twin) once before any rig runs: matplotlib's first figure holds the
    interpreter for about 0.1 s (fonts), as a first MuJoCo model may, long enough to miss a rig's watchdog."""

    job_results.plot_png([[Sample(0.0, 0.0, 0, frozenset()), Sample(0.1, 0.1, 0, frozenset())]], "warm-up")
    if twin:
        blob = pack(design_swing_up(RigParams(), "energy"))
        job_results.twin_with_pushes(blob, RigParams().to_dict(), 1, 250, RigParams().control_step_ms / 1000)


def _release_rig(store, rig: str) -> None:
    """A busy rig with no job of this runner running on it is free (its job went back to waiting)."""
    with store.engine.begin() as db:
        db.execute(tables.rigs.update().where(tables.rigs.c.rig == rig, tables.rigs.c.state == "busy")
                   .values(state="free", job_id=None))


def _awaiting_twin(store) -> list[int]:
    """Done jobs whose result still waits for its twin figure."""
    with store.engine.connect() as db:
        rows = db.execute(sa.select(tables.results.c.job_id, tables.results.c.summary)
                          .join(tables.jobs, tables.jobs.c.id == tables.results.c.job_id)
                          .where(tables.jobs.c.state == "done", tables.results.c.summary.contains(TWIN_PENDING)))
        return [row.job_id for row in rows if json.loads(row.summary).get("pushes") == TWIN_PENDING]


def _merge_summary(store, job_id: int, changes: dict) -> None:
    """Add `changes` to a stored result's summary (the twin's figures after the rig's)."""
    with store.engine.begin() as db:
        row = db.execute(sa.select(tables.results.c.summary).where(tables.results.c.job_id == job_id)).first()
        if row is not None:
            summary = {**json.loads(row.summary), **changes}
            db.execute(tables.results.update().where(tables.results.c.job_id == job_id)
                       .values(summary=json.dumps(summary)))
