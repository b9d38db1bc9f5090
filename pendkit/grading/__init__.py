"""The autograder the labs call: `check("01.decode_frame", decode_frame)` in a check cell."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from pendkit.grading.core import (
    TASKS,
    Diagnosis,
    Failed,
    GradingError,
    Task,
    TestResult,
    expect,
    format_report,
    load_hidden,
    load_lab,
    outcomes,
    run_task,
    task,
)
from pendkit.grading.modes import budget, mode, strict


class Score(float):
    """A check's score: a number to code, and nothing extra under the table in a notebook (no `Out: 0.0`)."""

    def _ipython_display_(self) -> None:
        pass


_NOTED_MISSING: set[int] = set()  # functions (by their code) already said to be missing


def check(task_id: str, fn: Any) -> float | None:
    """Run the public tests of `task_id` on `fn`, print a table, and return the score.

    Raises `GradingError` short of full marks only in strict mode (PENDKIT_GRADER_STRICT=1), so a
    student's notebook always runs to the end. Under `pendkit grade` the grader runs its own tests
    after the notebook, so checks only say so.
    """
    if mode() == "grade":
        print(f"{task_id}: graded by `pendkit grade` after the notebook has run")
        return None
    results = run_task(task_id, fn)
    print(_with_hidden_share(task_id, format_report(task_id, results)))
    score = sum(r.points for r in results)
    total = sum(r.max_points for r in results)
    if strict() and score < total:
        failed = "; ".join(f"{r.name}: {r.message}" for r in results if not r.passed)
        raise GradingError(f"{task_id} scored {score:g}/{total:g} in strict mode ({failed})")
    return Score(score)


def _with_hidden_share(task_id: str, report: str) -> str:
    """The report's first line says its points are the public tests' and what the hidden tests add."""
    hidden = TASKS[task_id].hidden_points if task_id in TASKS else None
    if not hidden:
        return report
    first, _, rest = report.partition("\n")
    share = f"{first} public; {hidden:g} more point{'s' if hidden != 1 else ''} from hidden tests when graded"
    return f"{share}\n{rest}" if rest else share


def attempt(fn: Callable, *args, **kwargs) -> Any:
    """Call a student's function for a demo cell; None while it is not implemented yet (said once per
    function, however many times a cell calls it)."""
    try:
        return fn(*args, **kwargs)
    except NotImplementedError:
        key = id(getattr(fn, "__code__", fn))  # a redefined function is said again
        if key not in _NOTED_MISSING:
            _NOTED_MISSING.add(key)
            print(f"{getattr(fn, '__name__', 'this function')} is not implemented yet: what follows uses nothing "
                  "from it")
        return None


__all__ = ["TASKS", "Diagnosis", "Failed", "GradingError", "Score", "Task", "TestResult", "attempt", "budget", "check",
           "expect", "format_report", "load_hidden", "load_lab", "mode", "outcomes", "run_task", "strict", "task"]
