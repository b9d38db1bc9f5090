"""Every graded task: correct answers get full marks; plausible mistakes lose points with a message that
points at the mistake (public and hidden tests together)."""

import math
from pathlib import Path

import numpy as np
import pytest

from pendkit.grading import load_hidden, load_lab, run_task

HIDDEN = Path(__file__).resolve().parents[2] / "solutions" / "tests"


def score(task_id, fn):
    results = run_task(task_id, fn, include_hidden=True)
    return sum(r.points for r in results), sum(r.max_points for r in results), \
        " ".join(r.message for r in results if not r.passed)


# every lab's answer key: its hidden tests' CORRECT and MISTAKES (solutions/tests/labNN_hidden.py)
def load_every_lab() -> dict[str, object]:
    from pendkit.grading.core import HIDDEN_MODULES

    for lab in sorted(path.name[3:5] for path in HIDDEN.glob("lab??_hidden.py")):
        load_lab(lab)
        for path in sorted(HIDDEN.glob(f"lab{lab}_*.py")):
            load_hidden(path)
    return {name[3:5]: module for name, module in HIDDEN_MODULES.items() if name.endswith("_hidden")}


KEYS = load_every_lab()
CORRECT = {task_id: fn for key in KEYS.values() for task_id, fn in key.CORRECT.items()}
# a mistake is (task, answer, words its feedback must contain[, the tests each of which must fail naming them])
MISTAKES = [(*mistake, set())[:4] for key in KEYS.values() for mistake in key.MISTAKES]


def test_every_lab_has_an_answer_key_for_every_task(all_tests_loaded):
    from pendkit.grading.core import TASKS

    graded = {task_id for task_id, t in TASKS.items() if t.tests and not task_id.endswith("prelab")}
    assert set(CORRECT) == graded
    assert {m[0] for m in MISTAKES} <= graded and len(KEYS) >= 11


@pytest.mark.parametrize("task_id", sorted(CORRECT))
def test_correct_answers_get_full_marks(all_tests_loaded, task_id):
    got, total, messages = score(task_id, CORRECT[task_id])
    assert got == total > 0, messages


@pytest.mark.parametrize("task_id, fn, words, each", MISTAKES, ids=[f"{m[0]}-{m[2]}" for m in MISTAKES])
def test_mistakes_lose_points_with_a_pointed_message(all_tests_loaded, task_id, fn, words, each):
    results = run_task(task_id, fn, include_hidden=True)
    assert sum(r.points for r in results) < sum(r.max_points for r in results)
    assert words in " ".join(r.message for r in results if not r.passed), [r.message for r in results]
    for result in results:
        if result.name in each:  # a test named here fails with the same diagnosis (public or hidden)
            assert not result.passed and words in result.message, (result.name, result.message)


def test_a_stub_scores_zero_and_says_not_implemented(all_tests_loaded):
    def stub(*args):
        raise NotImplementedError("not implemented yet")

    for task_id in CORRECT:
        got, total, messages = score(task_id, stub)
        assert got == 0 and "not implemented yet" in messages, task_id


def test_a_hanging_answer_times_out(all_tests_loaded, monkeypatch):
    monkeypatch.setenv("PENDKIT_CHECK_TIMEOUT_S", "0.2")

    def hang(theta, omega):
        while True:
            pass

    got, total, messages = score("00.reward", hang)
    assert got == 0 and "took longer than 0.2 s" in messages


def test_check_prints_and_strict_mode_raises(all_tests_loaded, monkeypatch, capsys):
    from pendkit.grading import GradingError, check

    monkeypatch.setenv("PENDKIT_MODE", "interactive")
    monkeypatch.setenv("PENDKIT_GRADER_STRICT", "0")
    assert check("01.wrap_delta", lambda new, old: new - old) == 2
    assert "FAIL  differences_across_the_seam" in capsys.readouterr().out
    monkeypatch.setenv("PENDKIT_GRADER_STRICT", "1")
    with pytest.raises(GradingError, match="01.wrap_delta scored 2/5"):
        check("01.wrap_delta", lambda new, old: new - old)
    assert check("01.wrap_delta", KEYS["01"].wrap_delta) == 5  # full marks never raise


@pytest.mark.parametrize("task_id, fn, misleading", [
    ("00.reward", lambda theta, omega: -theta**2 - 0.5 * omega**2, "Both terms are squared"),
    ("01.wrap_delta", lambda new, old: old - new, "keeps its sign"),
    ("01.wrap_delta", KEYS["01"].wrap_delta_wrapping_half_a_turn, "wrong sign"),
    ("01.decode_frame", KEYS["01"].decode_with_odd_parity, "Position = bits 15..6"),
    ("01.decode_frame", KEYS["01"].decode_with_odd_parity, "only one magnet bit"),
    ("02.velocity_rev_s", KEYS["02"].velocity_no_wrap, "Intervals need not be equal"),
    ("03.period_from_crossings", KEYS["03"].period_counting_both_directions, "without interpolation"),
    ("03.slew_rate", KEYS["03"].slew_interpolating_the_wrong_pair, "without interpolation"),
    ("03.slew_rate", lambda t, c, a: KEYS["03"].slew_rate(t, c, a) / 0.8, "nterpolat"),
    ("04.upright_matrices", lambda model: KEYS["04"].upright_matrices_with(model, gravity_sign=-1.0),
     "Use the model's fields"),
    # a message that names the cause carries no hint about another one
    ("00.upright_fraction", lambda angles: float(np.mean(np.abs(np.asarray(angles)) <= 0.3)), "Accept lists"),
    ("00.upright_fraction", lambda angles: float(np.mean(np.asarray(angles) < 0.3)), "the bound is strict"),
    ("00.upright_fraction", lambda angles: float(np.mean(np.asarray(angles) < 0.3)), "This test checks"),
    ("03.damping_ratio", lambda p: -CORRECT["03.damping_ratio"](p), "Average the decrement"),
    ("03.slew_rate", lambda t, c, a: KEYS["03"].slew_rate(t, c, a, from_zero=True), "This test checks"),
    ("05.path_limits", lambda arm, rev_s: (arm, rev_s), "This test checks"),
    ("05.terminal_cost", lambda x, up: KEYS["05"].terminal_cost(x, 0.0), "This test checks"),
    ("06.fit_latency", lambda samples: KEYS["06"].fit_latency(samples, subtract_floor=False), "This test checks"),
    ("06.fit_latency", lambda samples: KEYS["06"].fit_latency(samples, spread_above_floor=False), "This test checks"),
    ("00.upright_fraction", lambda angles: 100 * float(np.mean(np.abs(np.asarray(angles)) < 0.3)), "This test checks"),
    ("01.decode_frame", KEYS["01"].decode_off_by_one_shift, "MagINC or MagDEC alone"),
    ("04.upright_matrices", lambda model: KEYS["04"].upright_matrices_with(model, gravity_sign=-1.0),
     "come from M^-1"),
    ("03.slew_rate", lambda t, c, a: -KEYS["03"].slew_rate(t, c, a) if c[-1] < c[0] else KEYS["03"].slew_rate(t, c, a),
     "can go either way"),
])
def test_one_mistake_is_not_blamed_on_something_else(all_tests_loaded, task_id, fn, misleading):
    """A single bug fails the test about it; the other tests either pass or say they depend on it."""
    _, _, messages = score(task_id, fn)
    assert misleading not in messages, messages


def test_a_diagnosis_drops_the_hint_and_other_failures_keep_it():
    from pendkit.grading.core import Diagnosis, Failed, TestCase, expect, run_test

    def failing(raise_it):
        return TestCase("t", 1.0, lambda fn, rng: raise_it(), hint="Look elsewhere.")

    def plain():
        expect(False, "wrong")

    def named():
        expect(False, "wrong" + Diagnosis(": the sign is flipped"))

    def flagged():
        raise Failed("wrong: in seconds", hint=False)

    assert run_test(failing(plain), None).message == "wrong. This test checks: look elsewhere."
    assert run_test(failing(named), None).message == "wrong: the sign is flipped"
    assert run_test(failing(flagged), None).message == "wrong: in seconds"


def test_no_failure_says_only_that_it_is_wrong(all_tests_loaded):
    """A bare "is wrong" / "is not right" tells a student nothing: every failure a mistake causes shows the
    value it got (and what was expected, or why it is wrong)."""
    bare = []
    for task_id, fn, *_ in MISTAKES:
        for result in run_task(task_id, fn, include_hidden=True):
            message = result.message.split(". This test checks: ")[0]
            if not result.passed and ("is wrong" in message or "is not right" in message) and "got" not in message:
                bare.append((task_id, result.name, result.message))
    assert not bare, bare


def test_a_damping_ratio_near_the_answer_shows_how_far_off_it_is(all_tests_loaded):
    """Rounding must not hide the difference: 0.0199 against 0.02 reads as different numbers."""
    _, _, messages = score("03.damping_ratio", lambda p: 0.995 * KEYS["03"].log_decrement(p) / math.sqrt(
        4 * math.pi**2 + KEYS["03"].log_decrement(p) ** 2))
    assert "got 0.0199" in messages and "-0.50%" in messages, messages


def test_feedback_shows_numpy_numbers_as_numbers(all_tests_loaded):
    _, _, messages = score("09.time_to_upright_s", lambda angles, dt: np.float64(0.24))
    assert "got 0.24" in messages and "np.float64" not in messages, messages
    _, _, messages = score("09.balance_error_deg", lambda angles, dt: 76.9508191732133)
    assert "got 76.9508" in messages and "76.9508191732133" not in messages, messages


@pytest.mark.parametrize("task_id, fn, cause", [
    ("00.upright_fraction", lambda angles: 100 * float(np.mean(np.abs(np.asarray(angles)) < 0.3)), "percentage"),
    ("01.wrap_delta", KEYS["01"].wrap_delta_correcting_the_wrong_way, "correction went the wrong way"),
    ("02.firmware_mean", KEYS["02"].mean_without_zero_padding, "starts full of zeros"),
    ("02.firmware_mean", KEYS["02"].mean_centred, "looks ahead"),
    ("03.slew_rate", lambda t, c, a: KEYS["03"].slew_rate(t, c, a) / 0.8, "80 % of the step"),
    ("06.predict_angle", lambda theta, rate, d, w0: theta + rate * d - 0.5 * w0**2 * theta * d**2, "not minus"),
    ("06.predict_angle", lambda theta, rate, d, w0: theta + rate * d, "left out gravity"),
])
def test_every_test_a_mistake_fails_names_its_one_cause(all_tests_loaded, task_id, fn, cause):
    failed = [r for r in run_task(task_id, fn, include_hidden=True) if not r.passed]
    assert failed and all(cause in r.message for r in failed), [r.message for r in failed]
