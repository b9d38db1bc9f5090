"""Test-run settings shared by the unit tests and the notebooks that nbval runs.

Notebooks run in ci mode (short horizons) with the Agg backend; the kernels inherit this environment.
Solutions run strict: a check short of full marks fails the notebook.

The suite runs on pytest-xdist workers (`-n auto` in pyproject.toml), one file per worker at a time (a
notebook's cells share one kernel). Much of it waits on real time (virtual rigs, brokers, timeouts), so
there are more workers than cores, and the files that wait run beside the ones that compute
(tests/scheduling.py; keep `--dist loadfile` when overriding addopts); each computes on one
thread, or the workers' torch and BLAS threads fight over the cores (a 9 s R-DQN test took 97 s that way).
"""

import atexit
import itertools
import os
import shutil
import tempfile
from pathlib import Path

import pytest

os.environ.setdefault("PENDKIT_MODE", "ci")
os.environ.setdefault("MPLBACKEND", "Agg")
if "bubblewrap" in os.environ.get("PENDKIT_TESTS_WITHOUT", "").split(","):
    os.environ["PENDKIT_GRADE_SANDBOX"] = "off"  # the grader itself then behaves as on a machine without it
for _threads in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_threads, "1")  # read when torch and numpy load: the kernels inherit it too

ROOT = Path(__file__).resolve().parent
# Two tiers: `python -m pytest` runs every test but those marked `expensive` (training to a budget,
# identification of hidden rigs, real-time rig runs, whole classes graded); `python -m pytest --full` runs
# them too (CI does). Notebooks are marked here: lab 09's real-time rig runs.
FULL_TIER_NOTEBOOKS = ("09_deploy.ipynb",)


def _kernels_on_unix_sockets() -> None:
    """nbval's kernels talk over Unix sockets in a folder of their own. Over TCP, jupyter_client picks free
    ports and the kernel binds them a moment later, so two workers starting kernels at once can be handed the
    same port (a kernel "died before replying to kernel_info")."""
    try:
        import nbval.kernel
    except ImportError:
        return
    from pendkit.grading.local_kernels import unix_socket_kernel_manager

    if os.name != "posix":
        return
    folder = tempfile.mkdtemp(prefix="pendkit-kernels-")
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    names, manager = itertools.count(), nbval.kernel.KernelManager

    def on_unix_sockets(**kwargs):
        return unix_socket_kernel_manager(os.path.join(folder, f"k{next(names)}"), manager_class=manager, **kwargs)

    nbval.kernel.KernelManager = on_unix_sockets


_kernels_on_unix_sockets()


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_auto_num_workers(config):
    """`-n auto`: two workers more than the cores, at most 6 (memory: a worker with torch, MuJoCo and a
    notebook kernel holds about 1 GB). The two extra run the files that wait on real time beside the computing
    ones (tests/scheduling.py): on an idle 2-core machine 401 s against 467 s with one extra worker and files
    in collection order, the machine 98% busy against 85% (docs/results/test-suite.md). Without that
    scheduling, extra workers starved the notebooks' virtual rigs under load."""
    return min(6, (os.cpu_count() or 1) + 2)


def pytest_addoption(parser):
    parser.addoption("--files-in-order", action="store_true",
                     help="hand out files in collection order (xdist's loadfile), not waiting beside computing")
    parser.addoption("--full", action="store_true",
                     help="the full tier: the tests marked expensive too (CI runs it)")


@pytest.hookimpl(tryfirst=True, optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """`--dist loadfile` (the suite's) with files that wait on real time run beside computing ones
    (tests/scheduling.py); other modes, or `--files-in-order`, as xdist has them."""
    if config.getvalue("dist") != "loadfile" or config.getoption("files_in_order"):
        return None
    from tests.scheduling import make_scheduler

    return make_scheduler(config, log)


def _default_tier(config) -> bool:
    """The plain `python -m pytest`: no --full, no -m, no paths named (a file named runs all its tests)."""
    return (not config.getoption("full") and not config.option.markexpr
            and config.args_source == pytest.Config.ArgsSource.TESTPATHS)


def pytest_collection_modifyitems(config, items):
    for item in items:
        if Path(str(item.fspath)).name in FULL_TIER_NOTEBOOKS:
            item.add_marker(pytest.mark.expensive)
    if _default_tier(config):
        deselected = [item for item in items if item.get_closest_marker("expensive")]
        if deselected:
            config.hook.pytest_deselected(items=deselected)
            items[:] = [item for item in items if not item.get_closest_marker("expensive")]
    expensive_files = {Path(str(item.fspath)) for item in items if item.get_closest_marker("expensive")}
    items.sort(key=lambda item: Path(str(item.fspath)) not in expensive_files)  # stable: each file's order kept


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item):
    # nbval starts a notebook's kernel while setting up its first cell: set strictness before that.
    os.environ["PENDKIT_GRADER_STRICT"] = "1" if "solutions" in Path(str(item.fspath)).parts else "0"


def pytest_terminal_summary(terminalreporter):
    """Say what was skipped and why, once per reason (tests/system_needs.py names what each part needs),
    and what the full tier holds that this run left out."""
    if _default_tier(terminalreporter.config):
        terminalreporter.section("full tier")
        terminalreporter.write_line("the tests marked expensive (training to a budget, identification of hidden "
                                    "rigs, real-time rig runs, whole classes graded) were not run: "
                                    "`python -m pytest --full` runs them too (CI does)")
    reasons: dict[str, int] = {}
    for report in terminalreporter.stats.get("skipped", []):
        if isinstance(report.longrepr, tuple):
            reason = report.longrepr[2].removeprefix("Skipped: ")
            reasons[reason] = reasons.get(reason, 0) + 1
    if reasons:
        terminalreporter.section("skipped, and why")
        for reason, count in sorted(reasons.items(), key=lambda item: -item[1]):
            terminalreporter.write_line(f"{count:4d} {reason}")
