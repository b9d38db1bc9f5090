"""Grading at class scale, by `pendkit grade`'s own code, N notebooks at a time.

- `--class mixed` (default): lab 01 submissions (right, untouched, wrong, broken). Goal: <= 1.5 s per
  submission at --jobs 2 (2 cores).
- `--class solutions`: every lab's solution as one student each. Goal: every one at full marks, also with
  `--busy 2` (two processes keep the cores busy meanwhile) and with `--no-sandbox` (as on macOS).

    python benchmarks/bench_grade.py [--class mixed|solutions] [--submissions 30] [--jobs 2] [--busy 0]
                                     [--no-sandbox]
"""

from __future__ import annotations

import argparse
import multiprocessing
import tempfile
import time
from pathlib import Path

from pendkit.grading.notebook_files import nbformat
from pendkit.grading.report import grade_folder
from pendkit.grading.sandbox import isolation_problem

ROOT = Path(__file__).resolve().parents[1]


def variants() -> list:
    """Four kinds of submission, as a class hands them in."""
    solution = nbformat.read(ROOT / "solutions" / "01_encoder.ipynb", as_version=4)
    template = nbformat.read(ROOT / "labs" / "01_encoder.ipynb", as_version=4)
    wrong = nbformat.from_dict(solution)
    for cell in wrong.cells:
        if cell.cell_type == "code" and "def wrap_delta" in cell.source:
            cell.source = "def wrap_delta(new, old):\n    return new - old\n"
    crashing = nbformat.from_dict(solution)
    crashing.cells.insert(3, nbformat.v4.new_code_cell("1 / 0"))
    return [solution, template, wrong, crashing]


def mixed_class(folder: Path, submissions: int) -> None:
    kinds = variants()
    for k in range(submissions):
        (folder / f"s{k:03d}").mkdir(parents=True)
        nbformat.write(kinds[k % len(kinds)], folder / f"s{k:03d}" / "01_encoder.ipynb")


def solutions_class(folder: Path) -> None:
    for path in sorted((ROOT / "solutions").glob("*.ipynb")):
        (folder / path.stem).mkdir(parents=True)
        nbformat.write(nbformat.read(path, as_version=4), folder / path.stem / path.name)


def _spin(seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        pass


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--class", dest="kind", choices=("mixed", "solutions"), default="mixed")
    parser.add_argument("--submissions", type=int, default=30)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--busy", type=int, default=0, help="processes that keep the cores busy meanwhile")
    parser.add_argument("--no-sandbox", action="store_true", help="grade as on a machine without bubblewrap")
    args = parser.parse_args()
    isolate = False if args.no_sandbox or isolation_problem() is not None else None
    busy = [multiprocessing.Process(target=_spin, args=(3600,), daemon=True) for _ in range(args.busy)]
    for process in busy:
        process.start()
    try:
        with tempfile.TemporaryDirectory() as work:
            folder = Path(work) / "class"
            if args.kind == "mixed":
                mixed_class(folder, args.submissions)
            else:
                solutions_class(folder)
            started = time.perf_counter()
            grades = grade_folder(folder, Path(work) / "out", "01" if args.kind == "mixed" else None,
                                  ROOT / "solutions" / "tests", 60.0, 600.0, progress=False, jobs=args.jobs,
                                  isolate=isolate)
            elapsed = time.perf_counter() - started
    finally:
        for process in busy:
            process.kill()
    where = "on" if isolate is None else "off"
    print(f"isolation={where} busy={args.busy} jobs={args.jobs} submissions={len(grades)} "
          f"seconds_per_submission={elapsed / len(grades):.2f}")
    if args.kind == "mixed":
        print(f"distinct_scores={sorted({g.score for g in grades})}")
    else:
        full = [g for g in grades if g.score == g.max_score > 0]
        print(f"full_marks={len(full)}/{len(grades)}")
        for grade in grades:
            if grade not in full:
                print(f"  {grade.student}: {grade.score:g}/{grade.max_score:g} {grade.notes[:3]}")


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py (here: tests load this file alone)

    print_header()
    main()
