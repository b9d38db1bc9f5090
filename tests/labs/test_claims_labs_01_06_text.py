"""Labs 01-06: what each lab's text says its plots and printouts show is what the run shows (lab 01's one
seam crossing, lab 02's start-up mean and its two RMS figures, lab 03's fitted figures, lab 05's rigs)."""

import re

import numpy as np

from pendkit import encoder
from pendkit.labs.velocity_view import ALPHA, notes
from pendkit.sim.lab_readings import firmware_estimate_error_rev_s, free_swing_readings


def test_lab01_the_spin_crosses_the_seam_once_near_half_a_second_then_swings_about_one_turn():
    readings = free_swing_readings(period_ms=25.0, duration_s=3.0, offset_counts=317)
    jumps = np.diff(readings.raw_counts.astype(int))
    crossings = np.flatnonzero(np.abs(jumps) > 512)
    assert len(crossings) == 1 and 0.4 < readings.times_ms[crossings[0] + 1] / 1000 < 0.6
    assert readings.raw_counts[crossings[0]] > 990 and readings.raw_counts[crossings[0] + 1] < 30
    turns = np.cumsum([encoder.wrap_delta_counts(int(b), int(a)) for a, b in
                       zip(readings.raw_counts[:-1], readings.raw_counts[1:])]) / 1024
    assert turns.max() > 1 and abs(turns[-1] - 1) < 0.2


def test_lab02_the_mean_starts_at_a_quarter_and_its_full_buffer_rms_is_the_sweeps():
    readings = free_swing_readings(period_ms=25.0, duration_s=4.0)
    raw = encoder.finite_difference_rev_s(readings.raw_counts, readings.times_ms)
    mean = np.convolve(np.concatenate([np.zeros(3), raw]), np.ones(4) / 4, mode="valid")
    true = readings.true_velocity_rev_s[1:]
    assert round(mean[0], 2) == 0.55 and round(true[0], 1) == 2.2
    assert np.all(np.diff(mean[:4]) > 0.4) and mean[4] < mean[3]  # climbs three readings, then follows
    assert readings.times_ms[4] == 100.0  # the 4th difference ends 0.1 s in
    said = " ".join(notes(true, raw, mean, encoder.low_pass(raw, ALPHA)))
    overall, full = (float(x) for x in re.findall(r"firmware_mean: ([0-9.]+) .*?\(([0-9.]+) from", said)[0])
    assert overall > full and full == round(firmware_estimate_error_rev_s(25.0), 3)
