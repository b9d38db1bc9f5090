"""Find submissions, grade them all, and write Gradescope results.json files and a class CSV."""

from __future__ import annotations

import csv
import json
import re
from dataclasses import dataclass
from pathlib import Path

import nbformat

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
    output = "\n".join(grade.notes) if grade.notes else "Every cell ran."
    return {"score": grade.score, "execution_time": round(grade.execution_time_s), "output": output,
            "tests": tests}


def write_reports(grades: list[SubmissionGrade], out: Path) -> Path:
    """One results.json per student under `out/<student>/`, and `out/grades.csv`; returns the CSV path."""
    out.mkdir(parents=True, exist_ok=True)
    for grade in grades:
        folder = out / grade.student
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "results.json").write_text(json.dumps(gradescope_results(grade), indent=2) + "\n")
    task_ids = list(dict.fromkeys(t.task for g in grades for t in g.tasks))  # lab order
    csv_path = out / "grades.csv"
    with csv_path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["student", "lab", "score", "max_score", *task_ids, "notebook", "notes"])
        for grade in grades:
            per_task = {t.task: t.score for t in grade.tasks}
            writer.writerow([grade.student, grade.lab, f"{grade.score:g}", f"{grade.max_score:g}",
                             *[f"{per_task[t]:g}" if t in per_task else "" for t in task_ids],
                             grade.notebook, " | ".join(grade.notes)])
    return csv_path


def grade_folder(folder: Path, out: Path, lab: str | None, hidden_dir: Path | None, cell_timeout_s: float,
                 notebook_timeout_s: float, check_timeout_s: float | None = None,
                 progress: bool = True) -> list[SubmissionGrade]:
    """Grade every submission in `folder`; write the reports; return the grades."""
    submissions = find_submissions(folder, lab)
    grades = []
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(submissions), desc="grading", unit="notebook")
    for submission in submissions:
        if submission.lab is None:
            grade = SubmissionGrade(submission.student, str(submission.path), "?")
            grade.notes.append("cannot tell which lab this is: name it NN_name.ipynb or pass --lab NN")
        else:
            hidden = sorted(Path(hidden_dir).glob(f"lab{submission.lab}_*.py")) if hidden_dir else []
            grade = grade_notebook(submission.path, submission.student, submission.lab, hidden,
                                   cell_timeout_s, notebook_timeout_s, check_timeout_s)
        grades.append(grade)
        if bar is not None:
            bar.update(1)
    if bar is not None:
        bar.close()
    write_reports(grades, out)
    return grades
