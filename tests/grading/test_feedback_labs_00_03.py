"""Labs 00-03: each mistake the second walk-through made fails only the tests about it, each naming the real cause
(never "close" for an answer a turn off, never "without interpolation" for a student who interpolated), and the
edge cases the text requires (nan, ValueError) are graded."""

import math
from pathlib import Path

import numpy as np
import pytest

from pendkit.grading import run_task
from pendkit.grading.core import hidden_module

HIDDEN = Path(__file__).resolve().parents[2] / "solutions" / "tests"


def failed(task_id, fn):
    results = run_task(task_id, fn, include_hidden=True)
    return sum(r.points for r in results), {r.name: r.message for r in results if not r.passed}


def key(lab):
    return hidden_module(HIDDEN / f"lab{lab}_hidden.py")


def test_lab00_a_units_slip_costs_the_values_test_only_at_one_precision(all_tests_loaded):
    points, failures = failed("00.reward", lambda theta, omega: -theta**2 - 0.5 * omega**2)
    assert points == 1 and list(failures) == ["reward_values"], failures
    assert "should be -0.5000, got -19.7392: the velocity arrives in rad/s" in failures["reward_values"]


@pytest.mark.parametrize("fn, lost, words", [
    (lambda angle: math.atan2(math.sin(angle - math.pi), math.cos(angle - math.pi)), 3, "the interval is half-open"),
    (lambda angle: math.fmod(angle, 2 * math.pi) - math.pi, 3, "math.fmod keeps the angle's sign"),
])
def test_lab01_a_wrap_slip_is_named_and_never_called_close(all_tests_loaded, fn, lost, words):
    points, failures = failed("01.angle_from_upright", fn)
    assert points == 3 - lost and all(words in m for m in failures.values()), failures
    assert not any("close" in m or "wound several turns" in m for m in failures.values()), failures


def test_lab01_dividing_by_1023_costs_the_scale_and_the_range_and_says_so(all_tests_loaded):
    points, failures = failed("01.counts_to_angle", key("01").counts_over_1023)
    assert points == 2 and set(failures) == {"calibrated_counts_scale_to_radians", "whole_range"}, failures
    assert "6.2832 is outside [0, 2 pi) (it should be 6.2770)" in failures["whole_range"]
    assert not any("count or two" in m for m in failures.values())


def test_lab01_rejecting_one_magnet_bit_costs_its_own_test(all_tests_loaded):
    points, failures = failed("01.decode_frame", key("01").decode_rejecting_one_magnet_bit)
    assert points == 10 and list(failures) == ["one_magnet_bit_alone_is_valid"], failures


def test_lab02_a_units_slip_is_not_charged_to_the_seam_or_the_intervals(all_tests_loaded):
    points, failures = failed("02.velocity_rev_s", key("02").velocity_seconds)
    assert set(failures) == {"steady_rotation", "matches_the_firmware_on_a_twin_log"}, failures
    assert all("milliseconds" in m for m in failures.values())


def test_lab02_a_window_longer_than_the_data_divides_by_the_window(all_tests_loaded):
    assert failed("02.firmware_mean", key("02").CORRECT["02.firmware_mean"])[0] == 4
    points, failures = failed("02.firmware_mean", key("02").mean_without_zero_padding)
    assert "other_window_lengths" not in failures and "full of zeros" in failures["mean_of_the_last_window"]


def test_lab03_an_off_by_one_count_is_named_and_never_blamed_on_interpolation(all_tests_loaded):
    points, failures = failed("03.period_from_crossings", key("03").period_over_crossings)
    assert set(failures) == {"one_crossing_per_period", "a_twin_swing"}, failures
    assert all("divide by crossings - 1" in m for m in failures.values())
    assert not any("without interpolation" in m or "skipped" in m or "at or below 0" in m for m in failures.values())


def test_lab03_the_texts_edge_cases_are_graded(all_tests_loaded):
    points, failures = failed("03.period_from_crossings", key("03").period_returning_zero)
    assert points == 4 and list(failures) == ["fewer_than_two_crossings"]

    def slew_of_nothing(t, c, a):
        return key("03").slew_rate(t, c, a) if np.any(np.asarray(c) != c[0]) else 0.0

    points, failures = failed("03.slew_rate", slew_of_nothing)
    assert points == 5 and list(failures) == ["a_command_that_never_changes"]


def test_lab03_a_slew_from_zero_is_never_blamed_on_the_steps_direction(all_tests_loaded):
    points, failures = failed("03.slew_rate", lambda t, c, a: key("03").slew_rate(t, c, a, from_zero=True))
    assert set(failures) == {"a_ramp_after_a_lag", "random_ramps"}, failures
    assert all("not from 0" in m for m in failures.values()) and "either way" not in " ".join(failures.values())


def test_lab03_a_negative_zeta_keeps_the_students_period_in_the_comparison():
    from types import SimpleNamespace

    from pendkit.labs.free_swing import yours_against_the_kit

    fit = SimpleNamespace(natural_frequency_rad_s=5.289, natural_frequency_se=0.009, damping_ratio=0.073,
                          damping_ratio_se=0.003, cycles=6)
    lines = yours_against_the_kit(1.19, -0.0743, fit)
    assert "period 1.1900 s" in lines[0] and "upside down" in lines[0], lines


# --- the third walk-through: each new cause named, and never where it is not the cause

MIRRORED = "the angle runs the wrong way: subtract the offset from the reading (reading - offset)"
LATE = "your outputs are one step late: include the current value in the window"
SIGN = "the sign is flipped: new minus old"
LOW_BITS = "the frame's low 10 bits"


def test_lab01_a_reversed_subtraction_is_named_and_no_range_problem_is_suggested(all_tests_loaded):
    points, failures = failed("01.counts_to_angle", key("01").counts_reversed)
    assert points == 0 and set(failures) == {"calibrated_counts_scale_to_radians", "readings_below_the_offset_wrap",
                                             "whole_range"}, failures
    assert all(MIRRORED in m for m in failures.values()), failures
    assert not any("negative" in m or "[0, 2 pi)" in m or "This test checks" in m for m in failures.values())


def test_lab01_expected_and_got_are_printed_alike(all_tests_loaded):
    points, failures = failed("01.counts_to_angle", key("01").counts_mod_1023)
    assert "should be 6.27705 rad, got 6.27704: that is % 1023 and / 1023" in failures["whole_range"], failures
    assert "This test checks" not in failures["readings_below_the_offset_wrap"]  # no "not negative" for 6.27704
    _, failures = failed("01.counts_to_angle", key("01").counts_reversed)
    assert "should be 1.5708 rad, got 4.7124" in failures["calibrated_counts_scale_to_radians"], failures


def test_lab01_the_low_10_bits_are_never_called_the_whole_frame(all_tests_loaded):
    _, failures = failed("01.decode_frame", key("01").decode_low_bits)
    assert failures and all(LOW_BITS in m and "whole frame" not in m for m in failures.values()), failures
    _, failures = failed("01.decode_frame", key("01").decode_whole_frame)
    assert failures and all("whole frame" in m and LOW_BITS not in m for m in failures.values()), failures


def test_lab02_a_mean_one_step_late_is_named_under_the_plot_and_in_the_sweep(all_tests_loaded):
    from pendkit.labs.velocity_view import notes, period_sweep, sweep_lines
    from pendkit.sim.lab_readings import free_swing_readings

    points, failures = failed("02.firmware_mean", key("02").mean_one_step_late)
    assert points == 0 and all(LATE in m for m in failures.values()), failures
    readings = free_swing_readings(period_ms=25.0)
    raw = key("02").CORRECT["02.velocity_rev_s"](readings.raw_counts, readings.times_ms)
    lines = notes(readings.true_velocity_rev_s[1:], raw, key("02").mean_one_step_late(raw, 4), None, readings)
    assert LATE in lines[1], lines
    swept = sweep_lines(period_sweep(key("02").CORRECT["02.velocity_rev_s"], key("02").mean_one_step_late, [25]))
    assert any("yours part" in line and LATE in line for line in swept), swept


def test_lab02_a_velocity_sign_flip_is_named(all_tests_loaded):
    _, failures = failed("02.velocity_rev_s", key("02").velocity_old_minus_new)
    assert failures and all(SIGN in m for m in failures.values()), failures


def test_lab00_and_lab03_messages_say_what_their_numbers_are(all_tests_loaded):
    _, failures = failed("00.prelab", lambda: {"steps_per_second": 1 / 60, "episode_seconds": 500 * 60})
    assert all("takes the ms for seconds" in m for m in failures.values()) and len(failures) == 2, failures
    _, failures = failed("03.damping_ratio", lambda p: -key("03").CORRECT["03.damping_ratio"](p))
    assert "got -0.02, off by -200.00% of the right value" in failures["from_peak_amplitudes"], failures


@pytest.mark.parametrize("words, whose", [
    (MIRRORED, {"counts_reversed"}),
    (LATE, {"mean_one_step_late"}),
    (SIGN, {"velocity_old_minus_new"}),
    (LOW_BITS, {"decode_low_bits"}),
])
def test_a_new_diagnosis_fires_only_on_its_own_mistake(all_tests_loaded, words, whose):
    """Every right answer and every other known mistake of labs 00-03 is graded without these words."""
    answers = [(task_id, fn) for lab in ("00", "01", "02", "03") for task_id, fn in key(lab).CORRECT.items()]
    answers += [(m[0], m[1]) for lab in ("00", "01", "02", "03") for m in key(lab).MISTAKES
                if getattr(m[1], "__name__", "") not in whose]
    said = {(task_id, getattr(fn, "__name__", "?")): m for task_id, fn in answers
            for m in failed(task_id, fn)[1].values() if words in m}
    assert not said, said


# --- the fourth walk-through

def test_lab01_a_modulo_wrap_is_told_the_modulo_not_the_greater_or_equal(all_tests_loaded):
    points, failures = failed("01.wrap_delta", key("01").wrap_delta_by_modulo)
    assert points == 6 and list(failures) == ["half_a_turn_keeps_its_sign"], failures
    message = failures["half_a_turn_keeps_its_sign"]
    assert "wrap_delta(0, 512) should be -512, got 512: (0 - 512) % 1024 is +512: the modulo turned -512 into +512" \
        in message and ">= 512" not in message, message
    _, failures = failed("01.wrap_delta", key("01").wrap_delta_wrapping_half_a_turn)
    message = failures["half_a_turn_keeps_its_sign"]
    assert "wrap_delta(512, 0) should be 512, got -512" in message and "not >= 512" in message, message
    assert "modulo" not in message, message
