"""Lab 02: the period sweep runs on the student's own functions (a wrong one shows, with its cause), and the
reflection's and the instructor note's figures are the run's."""

import re
from pathlib import Path

import nbformat
import numpy as np

from pendkit import encoder
from pendkit.labs.velocity_view import period_sweep, rms, sweep_lines
from pendkit.rig import RigParams
from pendkit.sim.lab_readings import firmware_estimate_error_rev_s, free_swing_readings
from tests.grading.test_wrong_answers import KEYS
from tests.labs.student_loop import printed_by_lab

ROOT = Path(__file__).resolve().parents[2]
VELOCITY_IN_SECONDS = '''
def velocity_rev_s(positions, times_ms):
    positions = np.asarray(positions, dtype=np.int64)
    delta = np.diff(positions)
    delta = np.where(delta > 512, delta - 1024, np.where(delta < -512, delta + 1024, delta))
    return delta / 1024 / np.diff(np.asarray(times_ms, dtype=float))  # ms taken for seconds
'''


def text_of(notebook_name: str) -> str:
    notebook = nbformat.read(ROOT / "solutions" / notebook_name, as_version=4)
    return " ".join(" ".join(cell.source for cell in notebook.cells).split())


def test_lab02_right_functions_sweep_onto_the_firmwares_points():
    key = KEYS["02"]
    points = period_sweep(key.CORRECT["02.velocity_rev_s"], key.CORRECT["02.firmware_mean"], [5, 25, 100])
    assert all(p.yours_rev_s == p.firmware_rev_s and not p.note for p in points), points
    assert "part" not in " ".join(sweep_lines(points))


def test_lab02_the_notebooks_sweep_shows_a_velocity_in_the_wrong_unit_and_names_it():
    printed = printed_by_lab("02_velocity.ipynb", "period_sweep(velocity_rev_s",
                             {"velocity_rev_s": VELOCITY_IN_SECONDS})
    yours, firmware = (float(x) for x in re.search(r"5 ms: yours ([\d.]+) rev/s RMS, the firmware's ([\d.]+)",
                                                     printed).groups())
    assert yours > 10 * firmware, printed
    assert "yours part from the firmware's at your single differences: off by a factor of 1000; times are in " \
           "milliseconds" in printed
    part = next(line for line in printed.splitlines() if "yours part" in line)
    assert "differ from" not in part and "differs from" not in part, part  # "part from" says it once

VELOCITY_WITH_A_LEADING_ZERO = '''
def velocity_rev_s(positions, times_ms):
    positions = np.asarray(positions, dtype=np.int64)
    delta = np.diff(positions, prepend=positions[0])  # one value per reading: n + 1 for n pairs
    delta = np.where(delta > 512, delta - 1024, np.where(delta < -512, delta + 1024, delta))
    return delta / 1024 * 1000 / 25.0
'''


def test_lab02_a_velocity_of_the_wrong_length_is_named_and_run_all_goes_on():
    wrong = {"velocity_rev_s": VELOCITY_WITH_A_LEADING_ZERO}
    plotted = printed_by_lab("02_velocity.ipynb", "drawable(", wrong)
    assert plotted.startswith("velocity_rev_s returned 161 values for the 160 pairs of readings: it should return "
                              "160, one per pair; the plot leaves it out"), plotted
    swept = printed_by_lab("02_velocity.ipynb", "period_sweep(velocity_rev_s", wrong)  # the plot cell ran through
    said = [line for line in swept.splitlines() if "velocity_rev_s" in line]
    assert said == ["         yours is left out: your velocity_rev_s returns n + 1 values for n pairs of readings, "
                    "not one per pair"], swept


def test_lab02_single_differences_beat_the_mean_by_its_lag_as_the_note_says():
    readings = free_swing_readings(period_ms=25.0, duration_s=4.0)
    t_s, true = readings.times_ms / 1000, readings.true_velocity_rev_s
    raw = encoder.finite_difference_rev_s(readings.raw_counts, readings.times_ms)
    mean = np.convolve(np.concatenate([np.zeros(3), raw]), np.ones(4) / 4, mode="valid")
    fine = free_swing_readings(period_ms=5.0, duration_s=4.0)  # the truth between the 25 ms readings

    def truth_at(times_s):
        return np.interp(times_s, fine.times_ms / 1000, fine.true_velocity_rev_s)

    now = (rms(raw, true[1:]), rms(mean[3:], true[4:]))
    centred = (rms(raw, truth_at(t_s[1:] - 0.0125)), rms(mean[3:], truth_at(t_s[4:] - 0.050)))
    assert [round(x, 3) for x in now] == [0.044, 0.162] and now[1] == firmware_estimate_error_rev_s(25.0)
    assert [round(x, 3) for x in centred] == [0.015, 0.009]
    text = text_of("02_velocity.ipynb")
    assert "0.044 against 0.162 rev/s RMS" in text and "0.015 rev/s for single differences, 0.009 for the mean" in text
    assert "a quarter count per period (0.0098 rev/s at 25 ms instead of 0.039)" in text
    assert round(1 / 1024 / 0.025 / 4, 4) == 0.0098


def test_lab02_the_instructor_notes_figures_for_short_periods():
    params = RigParams()
    readings = free_swing_readings(period_ms=5.0)
    steps = np.abs([encoder.wrap_delta_counts(int(b), int(a))
                    for a, b in zip(readings.raw_counts[:-1], readings.raw_counts[1:])])
    assert np.median(steps) == 4 and round(float(np.mean(steps <= 1)), 2) == 0.20  # "one in five"
    raw = encoder.finite_difference_rev_s(readings.raw_counts, readings.times_ms)
    single = rms(raw, readings.true_velocity_rev_s[1:])
    assert (round(firmware_estimate_error_rev_s(5.0), 3), round(single, 3)) == (0.038, 0.080)
    assert [round(1 / 1024 / (ms / 1000), 3) for ms in (10, 5, 25)] == [0.098, 0.195, 0.039]
    assert round(firmware_estimate_error_rev_s(25.0), 2) == 0.16 and 0.5 / 0.025 == 20.0
    assert params.overspin_limit_rev_s == 2.0
    text = text_of("02_velocity.ipynb")
    for said in ("the RMS error once the buffer is full is about 0.16 rev/s, the quantisation step 0.039 rev/s",
                 "the aliasing limit 20 rev/s, far above the 2 rev/s over-spin stop",
                 "0.098 rev/s at 10 ms and 0.195 rev/s at 5 ms",
                 "a median of 4 counts apart, one in five of them 0 or 1 count apart",
                 "the mean of 4, 0.038 rev/s RMS, beats single differences, 0.080"):
        assert said in text, said
    assert "mostly 0 or 1 count apart" not in text
