"""Test-run settings shared by the unit tests and the notebooks that nbval runs.

Notebooks run in ci mode (short horizons) with the Agg backend; the kernels inherit this environment.
Solutions run strict: a check short of full marks fails the notebook.

The suite runs on pytest-xdist workers (`-n auto` in pyproject.toml), one file per worker at a time (a
notebook's cells share one kernel). Much of it waits on real time (virtual rigs, brokers, timeouts), so
there are more workers than cores; each computes on one thread, or the workers' torch and BLAS threads
fight over the cores (a 9 s R-DQN test took 97 s that way).
"""

import os
from pathlib import Path

import pytest

os.environ.setdefault("PENDKIT_MODE", "ci")
os.environ.setdefault("MPLBACKEND", "Agg")
for _threads in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_threads, "1")  # read when torch and numpy load: the kernels inherit it too

ROOT = Path(__file__).resolve().parent
# Files that take longest start first, so that no worker is left with one at the end: the real-time labs
# and anything with a test marked expensive.
SLOW_NOTEBOOKS = ("09_deploy.ipynb",)


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_auto_num_workers(config):
    """`-n auto`: a worker more than the cores (they wait on real time), at most 6 (memory: a worker with
    torch, MuJoCo and a notebook kernel holds about 1 GB). Two more than the cores bought little on 2 cores
    (453 s against 481 s) and a notebook kernel lost its port to another's (jupyter_client's port race)."""
    return min(6, (os.cpu_count() or 1) + 1)


def pytest_collection_modifyitems(config, items):
    def first(item) -> bool:
        path = Path(str(item.fspath))
        return path.name in SLOW_NOTEBOOKS or path in expensive_files

    expensive_files = {Path(str(item.fspath)) for item in items if item.get_closest_marker("expensive")}
    items.sort(key=lambda item: not first(item))  # stable: each file's own order is kept


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item):
    # nbval starts a notebook's kernel while setting up its first cell: set strictness before that.
    os.environ["PENDKIT_GRADER_STRICT"] = "1" if "solutions" in Path(str(item.fspath)).parts else "0"


def pytest_terminal_summary(terminalreporter):
    """Say what was skipped and why, once per reason (tests/system_needs.py names what each part needs)."""
    reasons: dict[str, int] = {}
    for report in terminalreporter.stats.get("skipped", []):
        if isinstance(report.longrepr, tuple):
            reason = report.longrepr[2].removeprefix("Skipped: ")
            reasons[reason] = reasons.get(reason, 0) + 1
    if reasons:
        terminalreporter.section("skipped, and why")
        for reason, count in sorted(reasons.items(), key=lambda item: -item[1]):
            terminalreporter.write_line(f"{count:4d} {reason}")
