"""Labs 07-10: a mistake whose cause the feedback names carries no hint about another cause, in every test it
fails (public and hidden); the answer keys' MISTAKES say which tests name it (tests/grading/test_wrong_answers.py)."""

from pathlib import Path

import pytest

from pendkit.grading import load_hidden, load_lab, run_task
from pendkit.grading.core import hidden_module

HIDDEN = Path(__file__).resolve().parents[2] / "solutions" / "tests"


def answer_key(lab: str):
    load_lab(lab)
    load_hidden(HIDDEN / f"lab{lab}_hidden.py")
    return hidden_module(HIDDEN / f"lab{lab}_hidden.py")


NAMED = [(task_id, fn, words, each) for lab in ("07", "08", "09", "10")
         for task_id, fn, words, *rest in answer_key(lab).MISTAKES for each in rest if each]


@pytest.mark.parametrize("task_id, fn, words, each", NAMED, ids=[f"{m[0]}-{m[2]}" for m in NAMED])
def test_a_named_cause_comes_without_a_hint_about_another(task_id, fn, words, each):
    from pendkit.grading.core import TASKS

    hints = {test.name: test.hint for test in TASKS[task_id].tests}
    failed = [r for r in run_task(task_id, fn, include_hidden=True) if not r.passed]
    assert failed, task_id
    for result in failed:  # the hint's words, however the feedback introduces them
        hint = hints[result.name][1:40]
        assert not hint or hint not in result.message, (result.name, result.message)
