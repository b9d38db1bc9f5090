"""Find submissions, grade them all, and write Gradescope results.json files and a class CSV."""

from __future__ import annotations

import csv
import io
import json
import os
import re
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path

from pendkit.errors import ConfigError
from pendkit.grading.core import load_hidden_source, load_lab
from pendkit.grading.notebook_files import nbformat
from pendkit.grading.runner import SubmissionGrade, grade_notebook

LAB_PREFIX = re.compile(r"^(\d\d)_")


@dataclass(frozen=True)
class Submission:
    student: str
    path: Path
    lab: str | None


def find_submissions(folder: Path, lab: str | None = None) -> list[Submission]:
    """`folder/<student>/*.ipynb` or `folder/<student>.ipynb`; only lab `lab` when given."""
    found = []
    for path in sorted(Path(folder).rglob("*.ipynb")):
        if ".ipynb_checkpoints" in path.parts:
            continue
        relative = path.relative_to(folder)
        student = relative.parts[0] if len(relative.parts) > 1 else path.stem
        detected = lab_of_notebook(path)
        if lab is not None and detected not in (None, lab):
            continue
        found.append(Submission(student, path, lab or detected))
    counts: dict[str, int] = {}
    for submission in found:
        counts[submission.student] = counts.get(submission.student, 0) + 1
    return [Submission(f"{s.student}/{s.path.stem}" if counts[s.student] > 1 else s.student, s.path, s.lab)
            for s in found]


def lab_of_notebook(path: Path) -> str | None:
    """The lab number from the notebook's metadata (written by `pendkit labs build`) or its file name."""
    try:
        metadata = nbformat.read(path, as_version=4).metadata
        lab = metadata.get("pendkit", {}).get("lab")
        if lab:
            return str(lab)
    except Exception:
        pass  # unreadable notebooks are reported by the runner
    match = LAB_PREFIX.match(path.name)
    return match.group(1) if match else None


def gradescope_results(grade: SubmissionGrade) -> dict:
    """Gradescope's results.json: total score, one entry per test, notes as the top-level output."""
    tests = []
    for task in grade.tasks:
        for result in task.results:
            tests.append({
                "name": f"{task.task} {task.title}: {result.name}",
                "score": result.points,
                "max_score": result.max_points,
                "output": result.message or "passed",
                "visibility": "after_published" if result.hidden else "visible",
            })
    for answer in grade.written:  # shown to the grader; its points are given by hand
        question = answer.question
        tests.append({"name": f"{question.id} {question.title} (written, {question.points:g} points, graded by hand)",
                      "score": 0, "max_score": 0, "output": answer.text or "(no answer)", "visibility": "visible"})
    output = "\n".join(grade.notes) if grade.notes else "Every cell ran."
    return {"score": grade.score, "execution_time": round(grade.execution_time_s), "output": output,
            "tests": tests}


def write_reports(grades: list[SubmissionGrade], out: Path) -> Path:
    """One results.json per student under `out/<student>/`, and `out/grades.csv`; returns the CSV path.
    Each file is written whole or not at all (a temporary file, then a rename)."""
    out.mkdir(parents=True, exist_ok=True)
    for grade in grades:
        folder = out / grade.student
        folder.mkdir(parents=True, exist_ok=True)
        _write_atomically(folder / "results.json", json.dumps(gradescope_results(grade), indent=2) + "\n")
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
    _write_atomically(csv_path, buffer.getvalue())
    return csv_path


def _write_atomically(path: Path, text: str) -> None:
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(handle, "w", newline="") as file:
            file.write(text)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


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


def grade_folder(folder: Path, out: Path, lab: str | None, hidden_dir: Path | None, cell_timeout_s: float,
                 notebook_timeout_s: float, check_timeout_s: float | None = None, progress: bool = True,
                 jobs: int = 1) -> list[SubmissionGrade]:
    """Grade every submission in `folder`, `jobs` at a time; write the reports; return the grades. Hidden
    files that cannot be loaded are skipped and reported on stderr; no submission can stop the others."""
    submissions = find_submissions(folder, lab)
    sources = read_hidden_sources(hidden_dir, {s.lab for s in submissions if s.lab is not None})
    for problem in load_suites(sources):
        print(f"pendkit grade: {problem}; grading without it", file=sys.stderr)
    settings = (cell_timeout_s, notebook_timeout_s, check_timeout_s)
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(submissions), desc="grading", unit="notebook")
    grades: list[SubmissionGrade] = []
    if jobs <= 1:
        for submission in submissions:
            grades.append(_grade_one(submission, settings))
            if bar is not None:
                bar.update(1)
    else:
        with ProcessPoolExecutor(jobs, mp_context=get_context("spawn"), initializer=_start_worker,
                                 initargs=(sources,)) as pool:
            futures = [pool.submit(_grade_one, submission, settings) for submission in submissions]
            for submission, future in zip(submissions, futures):
                try:
                    grades.append(future.result())
                except Exception as error:  # a worker that died: this submission only
                    grades.append(_failed_grade(submission, f"the grader failed on it ({type(error).__name__})"))
                if bar is not None:
                    bar.update(1)
    if bar is not None:
        bar.close()
    write_reports(grades, out)
    return grades


def _start_worker(sources) -> None:
    for problem in load_suites(sources):
        print(f"pendkit grade: {problem}", file=sys.stderr)


def _grade_one(submission: Submission, settings: tuple) -> SubmissionGrade:
    if submission.lab is None:
        return _failed_grade(submission, "cannot tell which lab this is: name it NN_name.ipynb or pass --lab NN")
    try:
        return grade_notebook(submission.path, submission.student, submission.lab, [], *settings)
    except Exception as error:  # a grader bug must cost this submission nothing but its own grade
        return _failed_grade(submission, f"the grader failed on it ({type(error).__name__}: {error})")


def _failed_grade(submission: Submission, note: str) -> SubmissionGrade:
    grade = SubmissionGrade(submission.student, str(submission.path), submission.lab or "?")
    grade.notes.append(note)
    return grade
