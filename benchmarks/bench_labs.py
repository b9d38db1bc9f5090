"""Wall time of every lab and solution notebook in ci mode (goal: at most 120 s each on 2 cores),
and of grading one submission with `pendkit grade`'s runner.

    python benchmarks/bench_labs.py [--labs 05 09]
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import nbformat
from nbclient import NotebookClient

from pendkit.grading.runner import grade_notebook

ROOT = Path(__file__).resolve().parents[1]


def run_seconds(path: Path, strict: bool) -> float:
    os.environ.update({"PENDKIT_MODE": "ci", "MPLBACKEND": "Agg", "PENDKIT_GRADER_STRICT": "1" if strict else "0"})
    notebook = nbformat.read(path, as_version=4)
    started = time.perf_counter()
    NotebookClient(notebook, timeout=600, kernel_name="python3",
                   resources={"metadata": {"path": str(path.parent)}}).execute()
    return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--labs", nargs="+", default=None, help="lab numbers (default: all)")
    args = parser.parse_args()

    def chosen(path: Path) -> bool:
        return args.labs is None or path.name[:2] in args.labs

    for tree, strict in (("solutions", True), ("labs", False)):
        for path in filter(chosen, sorted((ROOT / tree).glob("*.ipynb"))):
            print(f"notebook={tree}/{path.name} mode=ci wall_s={run_seconds(path, strict):.1f} goal_s=120",
                  flush=True)
    for path in filter(chosen, sorted((ROOT / "solutions").glob("*.ipynb"))):
        lab = path.name[:2]
        started = time.perf_counter()
        grade = grade_notebook(path, "bench", lab, sorted((ROOT / "solutions" / "tests").glob(f"lab{lab}_*.py")))
        print(f"grade={path.name} score={grade.score:g}/{grade.max_score:g} "
              f"wall_s={time.perf_counter() - started:.1f}", flush=True)


if __name__ == "__main__":
    main()
