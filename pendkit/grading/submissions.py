"""Find a class's submissions: every notebook in the class folder, and a row's worth for every entry that
holds none (a PDF, a zip, an empty folder), so that nothing handed in is silently left out of grades.csv."""

from __future__ import annotations

import dataclasses
import os
import re
from dataclasses import dataclass
from pathlib import Path

from pendkit.grading.core import known_labs
from pendkit.grading.notebook_files import read_submitted

LAB_PREFIX = re.compile(r"^(\d\d)_")
IGNORED_ENTRIES = {"__MACOSX", "Thumbs.db", "desktop.ini"}  # dot-files too (.DS_Store, checkpoints)


@dataclass(frozen=True)
class Submission:
    student: str
    path: Path
    lab: str | None
    folder: Path | None = None  # the student's own folder (None: a notebook lying flat in the class folder)
    problem: str | None = None  # why it cannot be graded, said in its row
    note: str | None = None  # said in its row, graded anyway
    this_run: bool = True  # False: another lab's notebook in a run of one lab (its row scores nothing here)


def find_submissions(folder: Path, lab: str | None = None, one_student: bool = False) -> list[Submission]:
    """`folder/<student>/*.ipynb` or `folder/<student>.ipynb`, every one of them (a notebook that cannot be
    graded, or not in this run, still gets its row saying why), and a row for every other entry of the class
    folder that holds no notebook (a PDF, a zip, an empty folder: 0 with the reason). Links are not followed.
    A folder whose notebooks are all lab files lying flat (`NN_name.ipynb`) is one student's: its rows take
    the folder's name.
    `one_student`: the folder is one student's (Gradescope's submission folder), whose files its notebooks
    may read."""
    folder = Path(folder)
    found = []
    notebooks = _notebooks(folder)
    # only the labs' own files (NN_name.ipynb) lying flat: one student's folder, its rows named after it
    own_folder_name = folder.resolve().name if notebooks and all(
        p.parent == folder and LAB_PREFIX.match(p.name) for p in notebooks) else None
    for path in notebooks:
        relative = path.relative_to(folder)
        student = relative.parts[0] if len(relative.parts) > 1 else own_folder_name or path.stem
        own_folder = folder / relative.parts[0] if len(relative.parts) > 1 else (folder if one_student else None)
        if path.is_symlink():
            found.append(Submission(student, path, lab, own_folder, problem=f"not graded: {relative} is a symbolic "
                                    "link; submit the notebook itself"))
            continue
        found.append(_with_lab(Submission(student, path, None, own_folder), lab))
    found = _flag_several(found)
    found += _entries_without_notebooks(folder, lab, one_student, {s.path.relative_to(folder).parts[0] for s in found})
    counts: dict[str, int] = {}
    for submission in found:
        counts[submission.student] = counts.get(submission.student, 0) + 1
    return [dataclasses.replace(s, student=f"{s.student}/{s.path.stem}") if counts[s.student] > 1 else s
            for s in found]


def _flag_several(found: list[Submission]) -> list[Submission]:
    """Two notebooks of one lab from one student: both graded, each row says so (which counts is the
    instructor's call)."""
    by_student_lab: dict[tuple[str, str | None], list[Submission]] = {}
    for submission in found:
        by_student_lab.setdefault((submission.student, submission.lab), []).append(submission)
    flagged = []
    for submission in found:
        same = by_student_lab[(submission.student, submission.lab)]
        if len(same) > 1 and submission.problem is None:
            names = ", ".join(s.path.name for s in same)
            warning = (f"CHECK: {submission.student} handed in {len(same)} notebooks for lab {submission.lab} "
                       f"({names}); each is graded in its own row: decide which one counts")
            submission = dataclasses.replace(submission, note="; ".join(n for n in (submission.note, warning) if n))
        flagged.append(submission)
    return flagged


def _entries_without_notebooks(folder: Path, lab: str | None, one_student: bool,
                               covered: set[str]) -> list[Submission]:
    """A row for each entry of the class folder that holds no notebook (for one student's folder: a row if
    it holds none at all), naming what it is and what to hand in instead."""
    entries = [e for e in sorted(folder.iterdir()) if not e.name.startswith(".") and e.name not in IGNORED_ENTRIES]
    if one_student:
        if covered:
            return []
        found = ", ".join(e.name for e in entries[:5]) or "nothing"
        return [Submission(folder.name, folder, lab, folder, problem=f"0 points: no notebook was handed in (found: "
                           f"{found}); hand in the lab's .ipynb file")]
    rows = []
    for entry in entries:
        if entry.name in covered:
            continue
        student = entry.name if entry.is_dir() else entry.stem
        by_name = LAB_PREFIX.match(entry.name)
        rows.append(Submission(student, entry, lab or (by_name.group(1) if by_name else None),
                               problem=f"0 points: {_not_a_notebook(entry)}"))
    return rows


def _not_a_notebook(entry: Path) -> str:
    if entry.is_symlink():
        return f"{entry.name} is a symbolic link; hand in the notebook itself"
    if entry.is_dir():
        inside = sorted(p.name for p in entry.iterdir() if not p.name.startswith("."))
        found = ", ".join(inside[:5]) + (", ..." if len(inside) > 5 else "") if inside else "the folder is empty"
        return f"no notebook in {entry.name}/ ({found}); hand in the lab's .ipynb file"
    kinds = {".pdf": "a PDF, which cannot be run", ".zip": "a zip archive: unpack it and hand in the .ipynb inside",
             ".html": "an HTML export, which cannot be run", ".py": "a Python file, not the lab's notebook"}
    kind = kinds.get(entry.suffix.lower(), "not a notebook (.ipynb)")
    return f"{entry.name} is {kind}; hand in the lab's .ipynb file"


def _notebooks(folder: Path) -> list[Path]:
    found = []
    for top, dirs, files in os.walk(folder):  # never into linked folders
        dirs[:] = sorted(d for d in dirs if d != ".ipynb_checkpoints")
        found += [Path(top) / name for name in files if name.endswith(".ipynb")]
    return sorted(found)


def _with_lab(submission: Submission, lab: str | None) -> Submission:
    """Which lab a notebook is: its metadata's (written by `pendkit labs build`), else its name's NN_ prefix,
    else `--lab`; a lab the kit does not have is named in the row."""
    labs = known_labs()
    stated = lab_of_notebook(submission.path)
    by_name = LAB_PREFIX.match(submission.path.name)
    by_name = by_name.group(1) if by_name else None
    detected = next((n for n in (stated, by_name) if n in labs), None)
    note = None
    if stated is not None and stated not in labs:
        note = f"the notebook's metadata says lab {stated!r}, which the kit does not have"
    if lab is not None:
        if detected is not None and detected != lab:
            return dataclasses.replace(submission, lab=detected, this_run=False, problem=f"not graded: this is lab "
                                       f"{detected}'s notebook, and this run grades lab {lab}")
        return dataclasses.replace(submission, lab=lab, note=note and f"{note}: graded as lab {lab}")
    if detected is None:
        return dataclasses.replace(submission, problem=f"not graded: {note or 'cannot tell which lab this is'}; name "
                                   "it NN_name.ipynb or pass --lab NN")
    return dataclasses.replace(submission, lab=detected, note=note and f"{note}: graded as lab {detected}")


def lab_of_notebook(path: Path) -> str | None:
    """The lab number the notebook's metadata states (written by `pendkit labs build`), if any."""
    try:
        lab = read_submitted(path).metadata.get("pendkit", {}).get("lab")
        return str(lab) if lab else None
    except Exception:
        return None  # unreadable notebooks are reported by the runner
