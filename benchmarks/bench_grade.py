"""Grading at class scale: a mixed set of lab 01 submissions (right, untouched, wrong, broken) graded by
`pendkit grade`'s own code, N at a time. Goal: <= 1.5 s per submission at --jobs 2 (2 cores).

    python benchmarks/bench_grade.py [--submissions 30] [--jobs 2]
"""

from __future__ import annotations

import argparse
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--submissions", type=int, default=30)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    kinds = variants()
    with tempfile.TemporaryDirectory() as work:
        folder = Path(work) / "class"
        for k in range(args.submissions):
            (folder / f"s{k:03d}").mkdir(parents=True)
            nbformat.write(kinds[k % len(kinds)], folder / f"s{k:03d}" / "01_encoder.ipynb")
        started = time.perf_counter()
        grades = grade_folder(folder, Path(work) / "out", "01", ROOT / "solutions" / "tests", 60.0, 300.0,
                              progress=False, jobs=args.jobs)
        elapsed = time.perf_counter() - started
    scores = sorted({g.score for g in grades})
    print(f"isolation={'on' if isolation_problem() is None else 'off'} distinct_scores={scores}")
    print(f"submissions={len(grades)} jobs={args.jobs} seconds_per_submission={elapsed / len(grades):.2f}")


if __name__ == "__main__":
    main()
