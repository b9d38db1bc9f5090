"""Labs 04-06: one mistake costs one test, whose message names its cause (the walk-through's findings: a
pre-lab slip carried on, a threshold taken with <= or a wrapped angle, a braking rule that follows the lab's
+1 convention, a percentile by another definition)."""

import math
from pathlib import Path

import numpy as np
import pytest

from pendkit.grading import run_task
from pendkit.grading.core import hidden_module

HIDDEN = Path(__file__).resolve().parents[2] / "solutions" / "tests"


def failed(task_id, fn):
    results = run_task(task_id, fn, include_hidden=True)
    return sum(r.points for r in results), [r for r in results if not r.passed]


def test_a_prelab_slip_carried_on_rightly_is_charged_once(all_tests_loaded):
    linearised = {"growth_per_step": 1 + 5 * 0.06, "steps_to_tenfold": math.log(10) / math.log(1.3)}
    points, failures = failed("04.prelab", lambda: linearised)
    assert points == 2 and [f.name for f in failures] == ["growth_per_step"], [f.message for f in failures]
    assert "e^0.3 ≈ 1.35" in failures[0].message


def test_a_wrong_second_answer_says_what_the_students_own_first_one_gives(all_tests_loaded):
    points, failures = failed("04.prelab", lambda: {"growth_per_step": 1.3, "steps_to_tenfold": 5.0})
    assert points == 1 and [f.name for f in failures] == ["growth_per_step", "steps_to_tenfold"]
    assert "ln 10 / ln 1.3 = 8.776 would count too" in failures[1].message, failures[1].message
    right_growth = {"growth_per_step": math.exp(0.3), "steps_to_tenfold": 5.0}
    points, failures = failed("04.prelab", lambda: right_growth)
    assert points == 2 and "would count too" not in failures[0].message


@pytest.mark.parametrize("variant, words", [
    ({"strict": False}, "the lab's thresholds are strict"),
    ({"wrap": True}, "it arrives wrapped to [-pi, pi)"),
])
def test_a_threshold_slip_costs_the_threshold_test_only_and_is_named(all_tests_loaded, variant, words):
    key = hidden_module(HIDDEN / "lab05_hidden.py")
    points, failures = failed("05.next_mode", lambda mode, theta, w: key.next_mode(mode, theta, w, **variant))
    assert points == 2 and [f.name for f in failures] == ["on_a_threshold"], [f.message for f in failures]
    assert words in failures[0].message and "CATCH_ANGLE_RAD" in failures[0].message


@pytest.mark.parametrize("variant", [{"fall": 0.8}, {"check_velocity": False}])
def test_a_hand_over_mistake_is_not_blamed_on_the_thresholds(all_tests_loaded, variant):
    key = hidden_module(HIDDEN / "lab05_hidden.py")
    _, failures = failed("05.next_mode", lambda mode, theta, w: key.next_mode(mode, theta, w, **variant))
    assert "on_a_threshold" not in [f.name for f in failures], [f.message for f in failures]


def test_a_rule_flipped_everywhere_is_named_though_it_keeps_the_plus_one_convention(all_tests_loaded):
    braking = hidden_module(HIDDEN / "lab05_hidden.py").pumping_braking_by_the_convention
    _, failures = failed("05.pumping_direction", braking)
    hidden = next(f for f in failures if f.name == "all_quadrants")
    assert "flipped in every quadrant" in hidden.message and "above horizontal" not in hidden.message
    assert "checks: check" not in " ".join(f.message for f in failures)


def test_a_nearest_rank_percentile_is_named_in_both_tests(all_tests_loaded):
    key = hidden_module(HIDDEN / "lab06_hidden.py")
    _, failures = failed("06.period_error_p99_ms", lambda t, n: key.nearest_rank_p99(np.abs(np.diff(t) - n) * 1000))
    assert {f.name for f in failures} == {"percentile_of_absolute_error", "other_periods"}
    assert all("another definition" in f.message and "np.percentile(errors_ms, 99)" in f.message for f in failures)


@pytest.mark.parametrize("slip", [{"coupling_sign": 1.0}, {"gravity_sign": -1.0}, {"coupling": False}])
def test_a_sign_slip_in_the_matrices_is_not_charged_to_the_parameters_test(all_tests_loaded, slip):
    key = hidden_module(HIDDEN / "lab04_hidden.py")
    points, failures = failed("04.upright_matrices", lambda model: key.upright_matrices_with(model, **slip))
    assert points == 1 and {f.name for f in failures} == {"match_the_linearisation", "random_rigs"}, \
        [(f.name, f.message) for f in failures]


@pytest.mark.parametrize("rule, words", [
    (lambda alpha, w: -int(np.sign(w * math.cos(alpha))), "np.sign"),
    (lambda alpha, w: -1 if w * math.cos(alpha) > 0 else 1, "treat |alpha' cos(alpha)| below 1e-9 as 0"),
])
def test_the_public_check_names_the_plus_one_convention(rule, words):
    from pendkit.grading import load_lab

    load_lab("05")
    results = run_task("05.pumping_direction", rule)
    failures = [r for r in results if not r.passed]
    assert [f.name for f in failures] == ["plus_one_where_no_push_adds_energy"], [f.message for f in failures]
    assert words in failures[0].message and "first push" in failures[0].message, failures[0].message


def test_a_rule_without_the_cosine_is_not_told_about_the_tolerance(all_tests_loaded):
    _, failures = failed("05.pumping_direction", lambda alpha, w: -1 if w > 0 else 1)
    assert "1e-9" not in " ".join(f.message for f in failures), [f.message for f in failures]


def test_catch_set_bounds_in_the_arguments_order_are_named(all_tests_loaded):
    _, failures = failed("05.catch_set", hidden_module(HIDDEN / "lab05_hidden.py").catch_set_in_argument_order)
    assert {f.name for f in failures} == {"box_around_upright", "random_thresholds"}
    assert all("in another order" in f.message and "[arm angle, pendulum angle, arm rate, pendulum rate]" in f.message
               for f in failures)


def test_fit_latency_all_equal_samples_is_graded_publicly():
    from pendkit.grading import load_lab

    load_lab("06")
    results = run_task("06.fit_latency", lambda samples: (min(samples), 0.0, float("nan")))
    failed_names = [r.name for r in results if not r.passed]
    assert "all_samples_equal" in failed_names and "return 0.0 then" in " ".join(r.message for r in results)
