"""The grader's side inside a student's kernel: find each task's function, test it, report as JSON.

`pendkit grade` appends one cell per task that calls `report_task`; the result is printed on one line
behind a marker with a per-run nonce, so the runner can tell it from anything the notebook printed.
Only test names and messages leave the kernel, never the hidden tests' code.
"""

from __future__ import annotations

import difflib
import json
from dataclasses import asdict
from pathlib import Path
from typing import Any

from pendkit.grading.core import TASKS, TestResult, load_hidden, load_lab, run_task

MARKER = "PENDKIT-GRADE-RESULT"


def report_task(task_id: str, namespace: dict[str, Any], hidden_paths: list[str], nonce: str) -> None:
    print(f"{MARKER}:{nonce}:" + json.dumps(grade_task(task_id, namespace, hidden_paths)))


def grade_task(task_id: str, namespace: dict[str, Any], hidden_paths: list[str]) -> dict[str, Any]:
    load_lab(task_id.split(".", 1)[0])
    for path in hidden_paths:
        if Path(path).exists():
            load_hidden(path)
    task = TASKS[task_id]
    fn = namespace.get(task.function)
    if fn is None or not callable(fn):
        message = f"function `{task.function}` not found: did you rename it or delete its cell?"
        candidates = [name for name, value in namespace.items() if callable(value) and not name.startswith("_")]
        close = difflib.get_close_matches(task.function, candidates, n=1, cutoff=0.6)
        if close:
            message += f" (found `{close[0]}`: keep the name `{task.function}`)"
        results = [TestResult(t.name, 0.0, t.points, False, message, t.hidden) for t in task.tests]
    else:
        results = run_task(task_id, fn, include_hidden=True)
    return {"task": task_id, "title": task.title, "results": [asdict(r) for r in results]}
