"""Pre-lab questions: a few numbers a student works out before the session, answered in the notebook as
`prelab()` returning a dict, one key per question.

The public suite checks only that every question has a numeric answer (the student sees which keys are
missing); the values are checked by hidden tests (the instructor's `labNN_hidden.py` calls
`prelab_answers`), so the answer key is not in the student's copy of the kit.
"""

from __future__ import annotations

import math

from pendkit.grading.core import Failed, Task, expect, is_real, shown, task


def prelab_task(lab: str, keys: tuple[str, ...]) -> Task:
    """The lab's `NN.prelab` task, with its public test: every key answered with a number."""
    prelab = task(f"{lab}.prelab", function="prelab", title="Pre-lab questions", hidden_points=len(keys))
    if any(t.name == "answers_every_question" for t in prelab.tests):
        return prelab

    @prelab.test(points=1, hint="Return a dict with one number per question, under the keys the lab names.")
    def answers_every_question(fn, rng):
        answers = _answers(fn)
        missing = [key for key in keys if key not in answers]
        expect(not missing, f"prelab() has no answer for {missing}: use exactly the keys {list(keys)}")
        not_numbers = [key for key in keys if not is_real(answers[key]) or not math.isfinite(answers[key])]
        expect(not not_numbers, f"the answers to {not_numbers} are not numbers (got "
               f"{[answers[k] for k in not_numbers]!r})")

    return prelab


def prelab_answers(lab: str, expected: dict[str, float], relative: float = 0.01,
                   where: str = "Work it out from the lab's background section.",
                   how: dict[str, str] | None = None) -> None:
    """Hidden tests, one point per question: the answer within `relative` of the expected value. A wrong
    answer is shown beside the expected one, with `how[key]` (the derivation, in the question's units) or,
    for a key without one, `where` (where the facts the question needs are)."""
    prelab = task(f"{lab}.prelab", function="prelab", title="Pre-lab questions")
    for key, value in expected.items():
        derivation = (how or {}).get(key, "")

        def check(fn, rng, key=key, value=value, derivation=derivation):
            answer = _answers(fn).get(key)
            if is_real(answer) and abs(answer - value) <= relative * abs(value) + 1e-9:
                return
            message = f"prelab()[{key!r}] should be {value:.4g}, got {shown(answer)}"
            raise Failed(f"{message}: {derivation}" if derivation else message, hint=not derivation)

        check.__name__ = key
        prelab.test(points=1, hidden=True, hint=where)(check)


def _answers(fn) -> dict:
    answers = fn()
    if not isinstance(answers, dict):
        raise Failed(f"prelab() should return a dict of answers, got {type(answers).__name__}")
    return answers
