"""One slip costs one task: lab 09's balance error finds its stretch with the student's `time_to_upright_s`, and
while it is tested that helper is the kit's, so an off-by-one in Task 1 is graded in Task 1 alone, in the
notebook's own check and by `pendkit grade` (the student's kernel) alike; a slip in the balance error itself
still costs its points, and the student's own helper is back afterwards."""

from pathlib import Path

import nbformat

from pendkit.grading import load_hidden, run_task
from pendkit.grading.runner import grade_notebook

HIDDEN = Path(__file__).resolve().parents[2] / "solutions" / "tests" / "lab09_hidden.py"

TASK_1_ONE_STEP_EARLY = '''
import numpy as np

UPRIGHT_RAD = 0.3


def time_to_upright_s(angles_from_upright_rad, dt_s):
    outside = np.nonzero(np.abs(np.asarray(angles_from_upright_rad, dtype=float)) >= UPRIGHT_RAD)[0]
    if len(outside) and outside[-1] == len(angles_from_upright_rad) - 1:
        return None
    return float(outside[-1] * dt_s) if len(outside) else 0.0  # one step early: the last step outside
'''
BALANCE_WITH_IT = '''
def balance_error_deg(angles_from_upright_rad, dt_s):
    start = time_to_upright_s(angles_from_upright_rad, dt_s)
    if start is None:
        return None
    tail = np.asarray(angles_from_upright_rad, dtype=float)[int(round(start / dt_s)):]
    return float(np.degrees(np.sqrt(np.mean(tail ** 2))))
'''


def scores(results) -> tuple[float, float]:
    return sum(r.points for r in results), sum(r.max_points for r in results)


def student(source: str) -> dict:
    namespace: dict = {}
    exec(source, namespace)  # noqa: S102 - the test's own student
    return namespace


def test_in_the_notebooks_check_a_slip_in_task_1_costs_task_1_alone():
    load_hidden(HIDDEN)
    namespace = student(TASK_1_ONE_STEP_EARLY + BALANCE_WITH_IT)
    upright, total_upright = scores(run_task("09.time_to_upright_s", namespace["time_to_upright_s"], True))
    balance, total_balance = scores(run_task("09.balance_error_deg", namespace["balance_error_deg"], True))
    assert upright < total_upright and balance == total_balance
    assert namespace["time_to_upright_s"].__module__ != "pendkit.features"  # the student's own is back
    # the same slip written into the balance error itself still costs its points, with its cause named
    inline = student(TASK_1_ONE_STEP_EARLY + BALANCE_WITH_IT.replace(
        "[int(round(start / dt_s)):]", "[max(int(round(start / dt_s)) - 1, 0):]"))
    results = run_task("09.balance_error_deg", inline["balance_error_deg"], True)
    assert scores(results)[0] < total_balance
    assert any("the stretch starts one step early" in r.message for r in results if not r.passed)


def test_graded_in_the_students_kernel_a_slip_in_task_1_costs_task_1_alone(tmp_path):
    notebook = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(TASK_1_ONE_STEP_EARLY),
                                               nbformat.v4.new_code_cell(BALANCE_WITH_IT)])
    path = tmp_path / "09_deploy.ipynb"
    nbformat.write(notebook, path)
    grade = grade_notebook(path, "ann", "09", [HIDDEN], 60.0, 240.0)
    tasks = {t.task: t for t in grade.tasks}
    assert tasks["09.time_to_upright_s"].score < tasks["09.time_to_upright_s"].max_score
    assert tasks["09.balance_error_deg"].score == tasks["09.balance_error_deg"].max_score
