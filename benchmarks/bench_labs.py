"""Wall time of every lab and solution notebook in ci mode (goal: at most 120 s each on 2 cores),
and of grading one submission with `pendkit grade`'s runner.

    python benchmarks/bench_labs.py [--labs 05 09] [--runs solutions labs grade]
    python benchmarks/bench_labs.py --interactive [--busy] [--show] [--labs 04 05 10]

`--interactive` runs each solution notebook with the budgets a class runs (PENDKIT_MODE=interactive) and
prints one line a lab: `lab=NN interactive_compute_s=X stated_min=Y outcome=ok|short` and the cells that
computed over 10 s without a progress bar (there should be none), the outcome being the
result the lab's text promises (OUTCOMES: read from what its cells print; "ran" where the lab promises no
number), so the time a class waits on the machine and the text's claims are measured, not estimated. `--busy` runs
a second process that keeps one core busy beside the notebook (a laptop with a browser and a video call:
the stated times must hold there too).
"""

from __future__ import annotations

import argparse
import os
import re
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


def _worst_below(limit: float):
    return lambda text: any(float(v) < limit for v in re.findall(r"worst error in the last 2 s ([\d.]+) deg", text))


def _all_solved(text: str) -> bool:
    return any(k == n for k, n in re.findall(r"busy room's WiFi: solved=(\d+)/(\d+)", text))


def _delay_aware_holds(text: str) -> bool:
    return re.search(r"^dqn\+actions +a policy that holds \(the rule\) after \d+ episodes", text, re.M) is not None


def _dqn_holds_unseen_starts(text: str) -> bool:
    reached = re.search(r"^a policy that holds \(the rule\) after \d+ episodes", text, re.M)
    judged = re.search(r"your verdict: held (\d+) of 10: solved", text)
    return reached is not None and judged is not None


def _policies_on_their_twins(text: str) -> bool:
    return all(re.search(rf"^{name}, on its twin +upright at +[\d.]+ s", text, re.M)
               for name in ("dqn-ideal", "td3-realistic"))


# What each lab's text promises a correct notebook shows (labs without a number: that it ran to the end).
OUTCOMES = {
    "07": _dqn_holds_unseen_starts,  # the student's DQN passes the rule, then 9+ of 10 starts it never saw
    "09": _policies_on_their_twins,  # both deployed policies come up on their own twins
    "04": _worst_below(1.0),  # "your K holds the pendulum within a fraction of a degree"
    "05": lambda text: re.search(r"time to upright: [\d.]+ s", text) is not None,
    "08": _delay_aware_holds,  # the delay-aware DQN reaches a policy that holds by the rule
    "10": _all_solved,  # the device's swing-up solves every start on the busy WiFi
}


RUNS = ("solutions", "labs", "grade")
BAR_SECONDS = 10.0  # a cell that computes longer shows a progress bar (issue 27)


def run_interactive(path: Path) -> tuple[float, str, list[str], list[str]]:
    """(wall seconds, everything the cells printed, the cells over BAR_SECONDS that showed no progress
    bar, the three slowest cells) of a notebook run with the class's budgets."""
    from datetime import datetime

    os.environ.update({"PENDKIT_MODE": "interactive", "MPLBACKEND": "Agg", "PENDKIT_GRADER_STRICT": "0"})
    notebook = nbformat.read(path, as_version=4)
    started = time.perf_counter()
    NotebookClient(notebook, timeout=3600, kernel_name="python3", record_timing=True,
                   resources={"metadata": {"path": str(path.parent)}}).execute()
    seconds = time.perf_counter() - started
    printed = "".join(o.get("text", "") for c in notebook.cells if c.cell_type == "code" for o in c.outputs
                      if o.get("output_type") == "stream" and o.get("name") == "stdout")
    silent, took_s = [], {}
    for index, cell in enumerate(notebook.cells):
        timing = cell.get("metadata", {}).get("execution", {})
        if cell.cell_type != "code" or "iopub.execute_input" not in timing:
            continue
        took = (datetime.fromisoformat(timing["shell.execute_reply"].replace("Z", "+00:00"))
                - datetime.fromisoformat(timing["iopub.execute_input"].replace("Z", "+00:00"))).total_seconds()
        took_s[index] = took
        shown = " ".join(o.get("text", "") + str(o.get("data", {})) for o in cell.outputs)
        if took > BAR_SECONDS and not re.search(r"\d+%\||it/s|episode/s|s/episode|FloatProgress|IntProgress", shown):
            silent.append(f"cell{index}:{took:.0f}s")
    slowest = sorted(took_s, key=took_s.get, reverse=True)[:3]
    return seconds, printed, silent, [f"cell{k}:{took_s[k]:.0f}s" for k in slowest]


class BusyCore:
    """A process that keeps one core busy until closed (a context manager)."""

    def __enter__(self):
        import subprocess
        import sys

        self.process = subprocess.Popen([sys.executable, "-c", "while True: pass"])
        return self

    def __exit__(self, *exc) -> None:
        self.process.kill()
        self.process.wait()


def interactive(labs: list[str] | None, busy: bool = False, show: bool = False) -> None:
    import contextlib

    with BusyCore() if busy else contextlib.nullcontext():
        for path in sorted((ROOT / "solutions").glob("*.ipynb")):
            lab = path.name[:2]
            if labs is not None and lab not in labs:
                continue
            stated = re.search(r"about (\d+) minutes", nbformat.read(path, as_version=4).cells[0].source)
            seconds, printed, silent, slowest = run_interactive(path)
            reached = OUTCOMES.get(lab, lambda text: True)(printed)
            print(f"lab={lab} interactive_compute_s={seconds:.0f} busy={busy} "
                  f"stated_min={stated.group(1) if stated else '-'} outcome={'ok' if reached else 'short'} "
                  f"cells_over_{BAR_SECONDS:.0f}s_without_bar={','.join(silent) or 'none'} "
                  f"slowest={','.join(slowest)}", flush=True)
            if show:  # what the cells printed: the lines a lab's text quotes
                print(printed, flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--labs", nargs="+", default=None, help="lab numbers (default: all)")
    parser.add_argument("--interactive", action="store_true", help="the class's budgets, one line a lab")
    parser.add_argument("--busy", action="store_true", help="with --interactive: a second process keeps a core busy")
    parser.add_argument("--show", action="store_true", help="with --interactive: print what each lab's cells printed")
    parser.add_argument("--runs", nargs="+", choices=RUNS, default=list(RUNS),
                        help="which to time: the solutions, the student templates (labs/), grading a solution")
    args = parser.parse_args()
    if args.interactive:
        interactive(args.labs, args.busy, args.show)
        return

    def chosen(path: Path) -> bool:
        return args.labs is None or path.name[:2] in args.labs

    for tree, strict in (("solutions", True), ("labs", False)):
        if tree not in args.runs:
            continue
        for path in filter(chosen, sorted((ROOT / tree).glob("*.ipynb"))):
            print(f"notebook={tree}/{path.name} mode=ci wall_s={run_seconds(path, strict):.1f} goal_s=120",
                  flush=True)
    if "grade" not in args.runs:
        return
    for path in filter(chosen, sorted((ROOT / "solutions").glob("*.ipynb"))):
        lab = path.name[:2]
        started = time.perf_counter()
        grade = grade_notebook(path, "bench", lab, sorted((ROOT / "solutions" / "tests").glob(f"lab{lab}_*.py")))
        print(f"grade={path.name} score={grade.score:g}/{grade.max_score:g} "
              f"wall_s={time.perf_counter() - started:.1f}", flush=True)


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py (here: tests load this file alone)

    print_header()
    main()
