"""Execute one submitted notebook headless and grade its functions, whatever the notebook does.

A cell that raises is noted and the run goes on. A cell that hangs or kills the kernel is left out and
the notebook is run again from the top without it (tasks already graded keep their results), so one
broken cell costs only what depends on it. Nothing that could not run scores a point. Cells tagged `demo`
(they run the rig or plot for the student, and define nothing a graded task needs) are not run: a tag a
student adds or removes can only cost them points or the grader time, never gain a point.
"""

from __future__ import annotations

import itertools
import logging
import math
import os
import shutil
import socket
import tempfile
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from pendkit.errors import ConfigError
from pendkit.grading.core import TASKS, TIMEOUT_CAP_VARIABLE, TestResult, load_hidden, load_lab, run_test
from pendkit.grading.local_kernels import unix_socket_kernel_manager
from pendkit.grading.notebook_client import MAX_KEPT_OUTPUT_BYTES, CappedNotebookClient, end_kernel, kernel_alive
from pendkit.grading.notebook_files import nbformat, read_submitted
from pendkit.grading.process_guard import ProcessGuard, kernel_pid, new_run_token, tree_cpu_s
from pendkit.grading.remote import KernelLost, KernelSession, RemoteFunction
from pendkit.grading.sandbox import Sandbox, isolation_problem
from pendkit.grading.staging import stage_submission
from pendkit.grading.written import WrittenAnswer, collect_answers

LOG = logging.getLogger("pendkit.grading")
KERNEL_ENV_ALLOWED = {"PATH", "LANG", "LANGUAGE", "LC_ALL", "LC_CTYPE", "LC_NUMERIC", "TZ", "TMPDIR", "TEMP", "TMP",
                      "HOME", "USER", "LOGNAME", "USERPROFILE", "APPDATA", "LOCALAPPDATA", "PROGRAMDATA",
                      "SYSTEMROOT", "WINDIR", "COMSPEC", "PATHEXT", "VIRTUAL_ENV", "CONDA_PREFIX", "PYTHONPATH",
                      "MUJOCO_GL", "PYOPENGL_PLATFORM", "OMP_NUM_THREADS", "MKL_NUM_THREADS",
                      "OPENBLAS_NUM_THREADS"}
MAX_RUNS = 5
_NOTEBOOKS = itertools.count()
DEMO_TAG = "demo"
GRADING_SLACK_S = 20.0


@dataclass
class TaskGrade:
    task: str
    title: str
    results: list[TestResult]

    @property
    def score(self) -> float:
        return sum(r.points for r in self.results)

    @property
    def max_score(self) -> float:
        return sum(r.max_points for r in self.results)


@dataclass
class SubmissionGrade:
    student: str
    notebook: str
    lab: str
    tasks: list[TaskGrade] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    execution_time_s: float = 0.0
    isolated: bool = False  # the kernel ran in the sandbox
    written: list[WrittenAnswer] = field(default_factory=list)  # graded by hand, not in the score

    @property
    def score(self) -> float:
        return sum(t.score for t in self.tasks)

    @property
    def max_score(self) -> float:
        return sum(t.max_score for t in self.tasks)


class _Restart(Exception):
    """The kernel must be replaced: a cell hung or killed it."""


def zero_grade(task_id: str, message: str) -> TaskGrade:
    task = TASKS[task_id]
    return TaskGrade(task_id, task.title, [TestResult(t.name, 0.0, t.points, False, message, t.hidden)
                                          for t in task.tests])


def grade_notebook(path: Path, student: str, lab: str, hidden_paths: list[Path], cell_timeout_s: float = 120.0,
                   notebook_timeout_s: float = 600.0, check_timeout_s: float | None = None,
                   isolate: bool | None = None, folder: Path | None = None,
                   run_token: str | None = None) -> SubmissionGrade:
    """Run `path` and grade lab `lab`'s tasks in it. Never raises for anything the notebook does.
    `folder`: the student's own folder, whose other files the notebook may read (None: the notebook alone).
    `isolate`: run the kernel in the bubblewrap sandbox (None: where it is available). `run_token`: the
    grading run's (process_guard); every process the notebook started is ended before this returns."""
    if not all(math.isfinite(t) and t > 0 for t in (cell_timeout_s, notebook_timeout_s, check_timeout_s or 1.0)):
        raise ConfigError("time limits must be positive and finite")
    started = time.monotonic()
    task_ids = [t.id for t in load_lab(lab)]
    for hidden_path in hidden_paths:
        try:
            load_hidden(hidden_path)
        except ConfigError as problem:
            LOG.warning("%s", problem)  # the instructor's file: said to them, not in a student's feedback
    grade = SubmissionGrade(student, str(path), lab)
    try:
        notebook = read_submitted(path)
    except Exception as error:
        grade.notes.append(f"could not read the notebook ({type(error).__name__}: {error}); nothing was run")
        grade.tasks = [zero_grade(t, "the notebook could not be read") for t in task_ids]
        return grade
    grade.written = collect_answers(notebook, lab)
    demos = sum(_is_demo(cell) for cell in notebook.cells)
    if demos:
        grade.notes.append(f"{demos} demonstration cells (tagged `{DEMO_TAG}`) were not run: they score nothing")
    scratch = Path(tempfile.mkdtemp(prefix="pendkit-submission-"))
    sandbox, sockets = None, None
    try:
        for what in stage_submission(Path(path), folder, scratch):
            grade.notes.append(f"left out {what}")
        if isolate is True or (isolate is None and isolation_problem() is None):
            sandbox = Sandbox(scratch, kernel_starts=MAX_RUNS)
        grade.isolated = sandbox is not None
        workdir = sandbox.work if sandbox is not None else scratch
        run = _Run(notebook, workdir, task_ids, cell_timeout_s, started + notebook_timeout_s, grade)
        run.check_timeout_s, run.sandbox = check_timeout_s, sandbox
        if sandbox is None:
            run.sockets = sockets = Path(tempfile.mkdtemp(prefix="pendkit-kernel-"))
        run.guard = ProcessGuard(f"{run_token or new_run_token()}:{os.getpid()}-{next(_NOTEBOOKS)}")
        with _grading_environment(check_timeout_s), run.guard:
            for start in range(MAX_RUNS):
                run.start = start
                try:
                    run.once()
                    break
                except _Restart:
                    continue
            else:
                grade.notes.append(f"gave up after {MAX_RUNS} kernel restarts")
        if run.guard.ended:
            grade.notes.append(f"{run.guard.ended} processes your notebook started were still running after it "
                               "and were stopped (a notebook should leave nothing running)")
        if run.dropped_output_bytes:
            grade.notes.append(f"your notebook printed or drew more than the {MAX_KEPT_OUTPUT_BYTES >> 20} MB of "
                               f"output the grader keeps: {run.dropped_output_bytes} bytes were not kept (they score "
                               "nothing either way)")
    finally:
        if sandbox is not None:
            sandbox.close()
        if sockets is not None:
            shutil.rmtree(sockets, ignore_errors=True)
        shutil.rmtree(scratch, ignore_errors=True)
    grade.tasks = [run.graded.get(t) or zero_grade(t, run.skipped.get(t, "not graded: the notebook did not "
                                                                         "get this far"))
                   for t in task_ids]
    grade.execution_time_s = time.monotonic() - started
    return grade


class _Run:
    def __init__(self, notebook, workdir: Path, task_ids, cell_timeout_s, deadline, grade) -> None:
        self.notebook, self.workdir, self.task_ids = notebook, workdir, task_ids
        self.cell_timeout_s, self.deadline, self.grade = cell_timeout_s, deadline, grade
        self.excluded: set[int] = set()
        self.graded: dict[str, TaskGrade] = {}
        self.skipped: dict[str, str] = {}
        self.noted_errors: set[int] = set()
        self.check_timeout_s: float | None = None
        self.sandbox: Sandbox | None = None
        self.sockets: Path | None = None  # the folder of the kernels' sockets without a sandbox
        self.start = 0  # which start of the kernel this is: each binds its sockets in a folder of its own
        self.guard: ProcessGuard | None = None
        self.dropped_output_bytes = 0

    def once(self) -> None:
        from nbclient.exceptions import CellTimeoutError, DeadKernelError

        notebook = nbformat.from_dict(self.notebook)  # a fresh copy per run
        km = (self.sandbox.kernel_manager(self.start) if self.sandbox is not None
              else unix_socket_kernel_manager(self.sockets / f"start-{self.start}"))
        client = CappedNotebookClient(notebook, km=km, timeout=math.ceil(self.cell_timeout_s), kernel_name="python3",
                                allow_errors=True, interrupt_on_timeout=False, record_timing=False,
                                shutdown_kernel="immediate",  # nothing of the kernel's is kept
                                resources={"metadata": {"path": str(self.workdir)}})
        started = False
        try:
            with client.setup_kernel(env={**kernel_environment(self.check_timeout_s), **self.guard.environment()}):
                started = True
                self.guard.watch(kernel_pid(client.km))
                for index, cell in enumerate(notebook.cells):
                    if cell.cell_type != "code" or index in self.excluded or _is_demo(cell):
                        continue
                    remaining = self.deadline - time.monotonic()
                    if remaining <= 1:
                        self.grade.notes.append(f"the notebook's time limit was reached at {_where(index, cell)}; "
                                                "later cells were not run")
                        break
                    client.timeout = math.ceil(max(1, min(self.cell_timeout_s, remaining)))
                    try:
                        client.execute_cell(cell, index)
                    except (CellTimeoutError, DeadKernelError) as error:
                        what = "ran past its time limit" if isinstance(error, CellTimeoutError) else "killed the kernel"
                        self.grade.notes.append(f"{_where(index, cell)} {what}; it was left out and the notebook "
                                                "run again without it")
                        self.excluded.add(index)
                        raise _Restart from error
                    except Exception as error:  # noqa: BLE001 - the kernel's messages no longer make sense
                        if not kernel_alive(client):  # nbclient saw the death its own way
                            self.grade.notes.append(f"{_where(index, cell)} killed the kernel; it was left out "
                                                    "and the notebook run again without it")
                            self.excluded.add(index)
                            raise _Restart from error
                        self._tampered(f"while {_where(index, cell)} ran", error)
                        return
                    self._note_error(index, cell)
                with _call_channel(self.sandbox) as channel_dir:
                    pid = kernel_pid(client.km)
                    session = KernelSession(client, channel_dir, cpu_s=lambda: tree_cpu_s(pid))
                    try:
                        for task_id in self.task_ids:
                            if task_id not in self.graded and task_id not in self.skipped:
                                self._grade_task(session, task_id)
                    except (_Restart, KernelLost):
                        raise
                    except Exception as error:  # noqa: BLE001 - as above, while the grader called a function
                        self._tampered("while the grader called your functions", error)
                    finally:
                        session.close()
        except RuntimeError as error:
            if started:
                raise
            # before any cell ran: the machine's fault, not the notebook's (another kernel took its port)
            self.grade.notes.append(f"the kernel did not start ({error}); it was started again")
            raise _Restart from error
        finally:
            self.dropped_output_bytes += client.dropped_output_bytes
            end_kernel(client, client.km or km)  # nbclient ends only the kernels and clients it made itself

    def _tampered(self, when: str, error: Exception) -> None:
        """The kernel's replies stopped making sense (its json, numpy or socket modules were replaced):
        said to the student as such; what was graded keeps its points, the rest gets none."""
        reason = (f"the grader could not read your kernel's messages {when} ({type(error).__name__}: "
                  f"{str(error)[:120]}): does your notebook replace or patch json, numpy, socket or the kit's "
                  "modules? Don't; 0 points for the tasks not graded before that")
        self.grade.notes.append(reason)
        for task_id in self.task_ids:
            if task_id not in self.graded:
                self.skipped.setdefault(task_id, "not graded: " + reason)

    def _grade_task(self, session: KernelSession, task_id: str) -> None:
        """Every test runs here, in the grader; only the student's function runs in their kernel."""
        task = TASKS[task_id]
        fn = RemoteFunction(session, task.function, task.kit_helpers)
        results: list[TestResult] = []
        for test in task.tests:
            remaining = self.deadline - time.monotonic()
            if remaining <= 0:
                self.skipped[task_id] = "not graded: the notebook's time limit was reached before its tests"
                return
            limit = min(test.timeout_s, self.check_timeout_s or test.timeout_s, remaining)
            session.start_test(limit)
            try:
                result = run_test(test, fn, time_limit=False)
            except KernelLost as error:
                self.skipped[task_id] = f"testing `{task.function}`: {error}; 0 points for this task"
                self.grade.notes.append(f"{task_id}: {self.skipped[task_id]}")
                raise _Restart from error
            results.append(result)
        self.graded[task_id] = TaskGrade(task_id, task.title, results)

    def _note_error(self, index: int, cell) -> None:
        for output in cell.get("outputs", []):
            if output.get("output_type") == "error" and index not in self.noted_errors:
                self.noted_errors.add(index)
                value = str(output.get("evalue", "")).splitlines()[0][:160] if output.get("evalue") else ""
                self.grade.notes.append(f"{_where(index, cell)} raised {output.get('ename')}: {value}")


@contextmanager
def _call_channel(sandbox: Sandbox | None):
    """A folder for the call socket that the kernel can reach (None where Python has no Unix sockets)."""
    if not hasattr(socket, "AF_UNIX"):
        yield None
    elif sandbox is not None:
        yield sandbox.root / "run"
    else:
        with tempfile.TemporaryDirectory(prefix="pendkit-calls-") as folder:
            yield Path(folder)


def _is_demo(cell) -> bool:
    tags = cell.get("metadata", {}).get("tags", [])
    return cell.get("cell_type") == "code" and isinstance(tags, list) and DEMO_TAG in tags


def _where(index: int, cell) -> str:
    first = next((line.strip() for line in cell.source.splitlines() if line.strip()), "")
    shown = first if len(first) <= 50 else first[:50] + "…"  # a cut line says so, never reads as another name
    return f"cell {index + 1} ({shown})" if first else f"cell {index + 1}"


def _grading_values(check_timeout_s: float | None) -> dict[str, str]:
    """Grade mode, never strict, no GUI backend, the cap on checks' time."""
    return {"PENDKIT_MODE": "grade", "PENDKIT_GRADER_STRICT": "0", "MPLBACKEND": "Agg",
            TIMEOUT_CAP_VARIABLE: "" if check_timeout_s is None else str(check_timeout_s)}


def kernel_environment(check_timeout_s: float | None) -> dict[str, str]:
    """The student's kernel gets this, not the grader's whole environment (an instructor's tokens and
    passwords stay out): what Python, locales and temporary folders need, and the grading values."""
    kept = {name: value for name, value in os.environ.items() if name.upper() in KERNEL_ENV_ALLOWED}
    return {**kept, **_grading_values(check_timeout_s)}


@contextmanager
def _grading_environment(check_timeout_s: float | None):
    """The grader's own process grades in grade mode too (its tests call the kit)."""
    wanted = _grading_values(check_timeout_s)
    saved = {name: os.environ.get(name) for name in wanted}
    os.environ.update(wanted)
    try:
        yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
