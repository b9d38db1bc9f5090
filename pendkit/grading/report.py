"""Find submissions, grade them all, and write Gradescope results.json files and a class CSV."""

from __future__ import annotations

import csv
import io
import json
import os
import shutil
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from multiprocessing import get_context
from pathlib import Path

from pendkit.errors import ConfigError, PendkitError
from pendkit.grading.core import known_labs, load_hidden_source, load_lab
from pendkit.grading.on_rigs import ON_RIGS_VARIABLE, judge_on_rigs
from pendkit.grading.process_guard import carrying, end_processes, new_run_token
from pendkit.grading.runner import SubmissionGrade, grade_notebook, zero_grade
from pendkit.grading.sandbox import isolation_problem
from pendkit.grading.submissions import Submission, find_submissions
from pendkit.safe_write import check_no_links, write_text


def gradescope_results(grade: SubmissionGrade) -> dict:
    """Gradescope's results.json: total score, one entry per test, notes as the top-level output."""
    tests = []
    for task in grade.tasks:
        for result in task.results:
            tests.append({
                "name": f"{task.task} {task.title}: {result.name}",
                "score": float(result.points),  # one number type in every results.json
                "max_score": float(result.max_points),
                "output": result.message or "passed",
                "visibility": "after_published" if result.hidden else "visible",
            })
    for answer in grade.written:  # shown to the grader; its points are given by hand
        question = answer.question
        tests.append({"name": f"{question.id} {question.title} (written, {question.points:g} points, graded by hand)",
                      "score": 0.0, "max_score": 0.0, "output": answer.text or "(no answer)", "visibility": "visible"})
    output = "\n".join(grade.notes) if grade.notes else "Every cell ran."
    return {"score": float(grade.score), "execution_time": round(grade.execution_time_s), "output": output,
            "tests": tests}


def write_reports(grades: list[SubmissionGrade], out: Path) -> Path:
    """One results.json per student under `out/<student>/`, and `out/grades.csv`; returns the CSV path.
    Each file is written whole or not at all (a temporary file, then a rename), never through a link planted
    in `out` (refused: `pendkit.safe_write`)."""
    out.mkdir(parents=True, exist_ok=True)
    for grade in grades:
        path = out / report_folder(grade.student) / "results.json"
        write_text(path, json.dumps(gradescope_results(grade), indent=2) + "\n", base=out, newline="", mode=0o600)
    task_ids = list(dict.fromkeys(t.task for g in grades for t in g.tasks))  # lab order
    questions = list(dict.fromkeys(a.question for g in grades for a in g.written))
    buffer = io.StringIO()
    writer = csv.writer(buffer)
    writer.writerow(["student", "lab", "score", "max_score", *task_ids,
                     *[f"{q.id} (by hand, /{q.points:g})" for q in questions], "notebook", "notes"])
    for grade in grades:
        per_task = {t.task: t.score for t in grade.tasks}
        answered = {a.question.id for a in grade.written if a.text}
        writer.writerow([grade.student, grade.lab, f"{grade.score:g}", f"{grade.max_score:g}",
                         *[f"{per_task[t]:g}" if t in per_task else "" for t in task_ids],
                         *["" if q.id in answered else "0 (no answer)" for q in questions],
                         grade.notebook, " | ".join(grade.notes)])
    csv_path = out / "grades.csv"
    write_text(csv_path, buffer.getvalue(), base=out, newline="", mode=0o600)  # grades: the instructor's eyes only
    return csv_path


def check_report_paths(submissions: list[Submission], out: Path) -> None:
    """Refuse, before any notebook runs, a link planted where a report would go (LinkRefused, one line)."""
    check_no_links(out / "grades.csv", out)
    for submission in submissions:
        check_no_links(out / report_folder(submission.student) / "results.json", out)


def report_folder(student: str) -> str:
    """Where a student's results.json goes under the output folder: never over grades.csv, never hidden."""
    first, *rest = student.split("/")
    if first == "grades.csv" or first.startswith("."):
        first = f"student-{first.lstrip('.')}"
    return "/".join([first, *rest])


def read_hidden_sources(hidden_dir: Path | None, labs: set[str]) -> dict[str, list[tuple[Path, bytes]]]:
    """Every hidden file of these labs, read once before any student code runs (a file a submission edits
    on disk later changes nothing); per lab, (path, bytes)."""
    sources: dict[str, list[tuple[Path, bytes]]] = {}
    for lab in sorted(labs):
        paths = sorted(Path(hidden_dir).glob(f"lab{lab}_*.py")) if hidden_dir else []
        sources[lab] = [(path.resolve(), path.read_bytes()) for path in paths]
    return sources


def load_suites(sources: dict[str, list[tuple[Path, bytes]]]) -> list[str]:
    """Load the public and hidden suites; a broken hidden file is skipped. Returns the problems found."""
    problems = []
    for lab, files in sources.items():
        load_lab(lab)
        for path, source in files:
            try:
                load_hidden_source(path, source)
            except ConfigError as problem:
                problems.append(str(problem))
    return problems


class GradingInterrupted(PendkitError):
    """The run was stopped (Ctrl-C); the grades so far were written."""


def grade_folder(folder: Path, out: Path, lab: str | None, hidden_dir: Path | None, cell_timeout_s: float,
                 notebook_timeout_s: float, check_timeout_s: float | None = None, progress: bool = True,
                 jobs: int = 1, one_student: bool = False, isolate: bool | None = None,
                 rig_queue=None) -> list[SubmissionGrade]:
    """Grade every submission in `folder`, `jobs` at a time; write the reports; return the grades. Hidden
    files that cannot be loaded are skipped and reported on stderr; no submission can stop the others.
    Every scratch folder lives under one folder of this run, removed however the run ends; an interrupted
    run writes what it graded and says so in the other rows. `isolate`: as `grade_notebook`'s, except that
    without a sandbox (None where there is none) a class of several students is refused: pass False to grade
    it anyway. Reports are written once every process a submission started has ended. `rig_queue`: a
    `pendkit.grading.on_rigs.RigQueue` whose rigs judge the tasks judged on a rig, once every notebook is graded
    (None: the twin judges them as each notebook is graded)."""
    if Path(out).resolve().is_relative_to(Path(folder).resolve()):
        raise ConfigError(f"the grades' folder {out} is inside the submissions' folder {folder}, where a student's "
                          "notebook could read or write them: choose --out outside it")
    submissions = find_submissions(folder, lab, one_student)
    check_report_paths(submissions, Path(out))
    if isolate is None and not one_student:
        _refuse_a_class_without_sandbox(submissions)
    sources = read_hidden_sources(hidden_dir, {s.lab for s in submissions if s.lab is not None and not s.problem})
    for problem in load_suites(sources):
        print(f"pendkit grade: {problem}; grading without it", file=sys.stderr)
    run_token = new_run_token()
    settings = (cell_timeout_s, notebook_timeout_s, check_timeout_s, isolate, run_token)
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(submissions), desc="grading", unit="notebook")
    grades: dict[int, SubmissionGrade] = {}
    scratch = Path(tempfile.mkdtemp(prefix="pendkit-grading-run-", dir=_short_temporary_folder()))
    try:
        with _rig_tests_wait(rig_queue is not None):
            if jobs <= 1:
                with _temporary_files_in(scratch):
                    for index, submission in enumerate(submissions):
                        grades[index] = _grade_one(submission, settings)
                        if bar is not None:
                            bar.update(1)
            else:
                _grade_in_pool(submissions, settings, sources, jobs, scratch, grades, bar)
        if rig_queue is not None:  # every kernel has ended: the rigs judge what the notebooks' tests kept

            judge_on_rigs([grades[k] for k in sorted(grades)], rig_queue)
    except KeyboardInterrupt:
        ordered = [grades.get(k) or _failed_grade(s, "not graded: the run was interrupted")
                   for k, s in enumerate(submissions)]
        end_processes(lambda: carrying(run_token, exact=False))
        write_reports(ordered, out)
        raise GradingInterrupted(f"interrupted: {len(grades)} of {len(submissions)} notebooks graded, the rest "
                                 f"marked so in {out / 'grades.csv'}") from None
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
        if bar is not None:
            bar.close()
    ordered = [grades[k] for k in range(len(submissions))]
    end_processes(lambda: carrying(run_token, exact=False))  # what a killed worker could not end
    write_reports(ordered, out)
    return ordered


class SandboxRequired(ConfigError):
    """A class graded where no sandbox can hold a student's code, without saying so."""


def _refuse_a_class_without_sandbox(submissions: list[Submission]) -> None:
    problem = isolation_problem()
    students = {s.student.split("/")[0] for s in submissions if s.problem is None}
    if problem is not None and len(students) > 1:
        raise SandboxRequired(
            f"no sandbox here ({problem}): a student's notebook would run as you, and one submission could "
            f"change or zero the grades of the other {len(students) - 1} students. Install bubblewrap on Linux, "
            "grade one student's folder at a time, or pass --no-sandbox to grade the class anyway")


def _grade_in_pool(submissions, settings, sources, jobs, scratch, grades, bar) -> None:
    """A pool of `jobs` workers; a worker that dies (killed for memory, say) breaks the pool: the notebooks
    it took down with it are graded again, each in a pool of its own, so only the one that killed its
    worker twice loses its grade."""
    def pool(workers: int) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(workers, mp_context=get_context("spawn"), initializer=_start_worker,
                                   initargs=(sources, str(scratch)))

    broken: list[int] = []
    with pool(jobs) as executor:
        futures = {executor.submit(_grade_one, submission, settings): k for k, submission in enumerate(submissions)}
        for future in as_completed(futures):
            k = futures[future]
            try:
                grades[k] = future.result()
            except BrokenProcessPool:
                broken.append(k)
                continue
            except Exception as error:  # noqa: BLE001 - a grader bug costs this submission only
                grades[k] = _failed_grade(submissions[k], f"the grader failed on it ({type(error).__name__})")
            if bar is not None:
                bar.update(1)
    for k in sorted(broken):
        with pool(1) as executor:
            try:
                grades[k] = executor.submit(_grade_one, submissions[k], settings).result()
            except BrokenProcessPool:
                grades[k] = _failed_grade(submissions[k], "the grading process running this notebook was killed, "
                                          "twice (it used too much memory or time?): 0 points")
        if bar is not None:
            bar.update(1)


def _short_temporary_folder() -> str | None:
    """/tmp on Linux and macOS unless a caller chose a folder: the kernels' sockets live under the run's
    scratch folder, and a socket's path may not pass 104-108 bytes (macOS's own temporary folder is
    already 49)."""
    if tempfile.tempdir is None and os.name == "posix" and os.access("/tmp", os.W_OK):
        return "/tmp"
    return None


@contextmanager
def _rig_tests_wait(waiting: bool):
    """With a rig queue, the tests judged on a rig keep their blobs (`pendkit.grading.on_rigs`); set in this
    process's environment, which the grading workers inherit and students' kernels do not."""

    saved = os.environ.pop(ON_RIGS_VARIABLE, None)
    if waiting:
        os.environ[ON_RIGS_VARIABLE] = "queue"
    try:
        yield
    finally:
        os.environ.pop(ON_RIGS_VARIABLE, None)
        if saved is not None:
            os.environ[ON_RIGS_VARIABLE] = saved


@contextmanager
def _temporary_files_in(folder: Path):
    saved, tempfile.tempdir = tempfile.tempdir, str(folder)
    try:
        yield
    finally:
        tempfile.tempdir = saved


def _start_worker(sources, scratch: str) -> None:
    tempfile.tempdir = scratch  # every scratch folder of this worker, removed by the run if the worker is killed
    for problem in load_suites(sources):
        print(f"pendkit grade: {problem}", file=sys.stderr)


def _grade_one(submission: Submission, settings: tuple) -> SubmissionGrade:
    if submission.problem is not None:
        return _failed_grade(submission, submission.problem)
    *limits, run_token = settings
    try:
        grade = grade_notebook(submission.path, submission.student, submission.lab, [], *limits,
                               folder=submission.folder, run_token=run_token)
    except Exception as error:  # a grader bug must cost this submission nothing but its own grade
        return _failed_grade(submission, f"the grader failed on it ({type(error).__name__}: {error})")
    if submission.note is not None:
        grade.notes.insert(0, submission.note)
    return grade


def _failed_grade(submission: Submission, note: str) -> SubmissionGrade:
    """0 on every task of its lab (when known), with the reason in its notes."""
    grade = SubmissionGrade(submission.student, str(submission.path), submission.lab or "?")
    grade.notes.append(note)
    if submission.this_run and submission.lab in known_labs():
        grade.tasks = [zero_grade(t.id, note) for t in load_lab(submission.lab)]
    return grade
