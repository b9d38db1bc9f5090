"""Pre-lab questions: every lab has them; the solutions' answers get full marks, wrong or missing ones
lose the hidden points with a message naming the key, and the public check gives no value away."""

from pathlib import Path

import nbformat
import pytest

from pendkit.grading import TASKS, run_task
from pendkit.labs.build import lab_files, strip_solutions

ROOT = Path(__file__).resolve().parents[2]
LABS = [lab.number for lab in lab_files(ROOT / "solutions", ROOT / "labs")]


def solution_prelab(lab: str):
    path = next((ROOT / "solutions").glob(f"{lab}_*.ipynb"))
    cell = next(c for c in nbformat.read(path, as_version=4).cells if c.source.startswith("def prelab("))
    namespace: dict = {}
    exec(cell.source, namespace)  # the instructor's own notebook
    return namespace["prelab"]


def scored(lab, fn):
    results = run_task(f"{lab}.prelab", fn, include_hidden=True)
    return sum(r.points for r in results), sum(r.max_points for r in results), [r for r in results if not r.passed]


@pytest.mark.parametrize("lab", LABS)
def test_the_solutions_answers_get_full_marks(all_tests_loaded, lab):
    got, total, failed = scored(lab, solution_prelab(lab))
    assert total >= 3 and got == total, [f.message for f in failed]


@pytest.mark.parametrize("lab", LABS)
def test_a_wrong_answer_loses_its_point_and_names_its_key(all_tests_loaded, lab):
    right = solution_prelab(lab)()
    key = next(iter(right))
    wrong = dict(right, **{key: right[key] * 1.1 + 0.5})
    got, total, failed = scored(lab, lambda: wrong)
    assert got == total - 1 and len(failed) == 1 and repr(key) in failed[0].message


def test_missing_keys_and_non_numbers_are_named_and_no_value_is_shown(all_tests_loaded):
    right = solution_prelab("04")()
    results = run_task("04.prelab", lambda: {"growth_per_step": "about 1.3"})
    message = " ".join(r.message for r in results)
    assert "'steps_to_tenfold'" in message and "not numbers" not in message  # the missing key comes first
    results = run_task("04.prelab", lambda: dict(right, steps_to_tenfold="about eight"))
    assert "['steps_to_tenfold']" in " ".join(r.message for r in results)
    assert not any(str(round(v, 3)) in r.message for r in results for v in right.values())
    assert run_task("04.prelab", lambda: [1.35, 7.7])[0].message.startswith("prelab() should return a dict")


def test_the_student_copy_asks_without_answering():
    path = next((ROOT / "solutions").glob("05_*.ipynb"))
    cell = next(c for c in nbformat.read(path, as_version=4).cells if c.source.startswith("def prelab("))
    student = strip_solutions(cell.source, "05 prelab")
    assert "NotImplementedError" in student and "energy_hanging" not in student
    assert TASKS["05.prelab"].function == "prelab"


@pytest.mark.parametrize("lab", LABS)
def test_the_notebook_does_not_print_or_state_its_prelab_answers(lab):
    """A pre-lab answered by the lab itself asks for look-up, not thought (04's 1.35 per step once sat in a
    markdown cell; 09's stale steps in Task 3's text)."""
    path = next((ROOT / "solutions").glob(f"{lab}_*.ipynb"))
    answers = solution_prelab(lab)()
    cells = [c for c in nbformat.read(path, as_version=4).cells
             if not c.source.startswith("def prelab(") and "instructor" not in c.metadata.get("tags", [])]
    text = " ".join(c.source for c in cells)
    for key, value in answers.items():
        if isinstance(value, float) and not float(value).is_integer():
            for shown in {f"{value:.2f}", f"{value:.3f}"}:
                assert shown not in text, f"lab {lab} states {key} = {shown} outside the pre-lab"


def test_a_wrong_answer_is_shown_beside_the_expected_one_and_how_to_get_it(all_tests_loaded):
    """1/60 for the steps per second: the feedback says what a step is in seconds, not only "not right"."""
    results = run_task("00.prelab", lambda: {"steps_per_second": 1 / 60, "episode_seconds": 30.0}, include_hidden=True)
    message = " ".join(r.message for r in results if not r.passed)
    assert "should be 16.67, got 0.0166667" in message and "1 / 0.06" in message, message
