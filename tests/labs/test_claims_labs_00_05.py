"""Labs 00-05: the checks say what the hidden tests add, and each stated figure or note is what the run
shows (lab 02's estimate notes, lab 03's free swing, lab 05's hand-over and over-spin)."""

import math
import tempfile
from pathlib import Path

import numpy as np
import pytest

import pendkit
from pendkit import encoder
from pendkit.grading import check
from pendkit.grading.core import TASKS, kit_hidden_tests, load_hidden, load_lab
from pendkit.labs.free_swing import swing_peaks, yours_against_the_kit
from pendkit.labs.velocity_view import ALPHA, notes
from pendkit.sim.lab_readings import free_swing_readings

LABS = ["00", "01", "02", "03", "04", "05", "06"]


@pytest.fixture(scope="module")
def every_test_loaded():
    for lab in LABS:
        load_lab(lab)
        for path in sorted(kit_hidden_tests().glob(f"lab{lab}_*.py")):
            load_hidden(path)


def test_each_task_declares_what_its_hidden_tests_add(every_test_loaded):
    for task in (t for t in TASKS.values() if t.id[:2] in LABS):
        hidden = task.max_points(hidden=True) - task.max_points()
        assert task.hidden_points == hidden, f"{task.id}: declares {task.hidden_points}, hidden tests give {hidden}"


def test_a_check_names_its_public_share_and_the_hidden_rest(every_test_loaded, monkeypatch, capsys):
    monkeypatch.setenv("PENDKIT_MODE", "interactive")
    monkeypatch.setenv("PENDKIT_GRADER_STRICT", "0")
    check("00.reward", lambda theta, omega: -theta**2 - 0.5 * (omega / (2 * math.pi)) ** 2)
    first = capsys.readouterr().out.splitlines()[0]
    assert first.endswith("2/2 points public; 1 more point from hidden tests when graded"), first


def test_lab02_notes_name_a_swapped_alpha_and_an_unpadded_mean():
    readings = free_swing_readings(period_ms=25.0, duration_s=4.0)
    raw = encoder.finite_difference_rev_s(readings.raw_counts, readings.times_ms)
    seen_so_far = np.array([np.mean(raw[max(0, i - 3):i + 1]) for i in range(len(raw))])
    said = " ".join(notes(readings.true_velocity_rev_s[1:], raw, seen_so_far, encoder.low_pass(raw, 1 - ALPHA)))
    assert "starts full of zeros" in said and "alpha and 1 - alpha are swapped" in said
    right = np.convolve(np.concatenate([np.zeros(3), raw]), np.ones(4) / 4, mode="valid")
    said = " ".join(notes(readings.true_velocity_rev_s[1:], raw, right, encoder.low_pass(raw, ALPHA), readings))
    assert ";" not in said, said


def test_lab02_notes_name_single_differences_in_rad_s():
    readings = free_swing_readings(period_ms=25.0, duration_s=4.0)
    raw = 2 * np.pi * encoder.finite_difference_rev_s(readings.raw_counts, readings.times_ms)
    said = notes(readings.true_velocity_rev_s[1:], raw, None, None, readings)[0]
    assert said.startswith("single differences") and "these are rad/s" in said, said


@pytest.fixture(scope="module")
def free_swing():
    """Lab 03's free swing (ci's 200 steps): times, angles from the bottom, the kit's fit."""
    from pendkit.control.sysid import identify_free_swing
    from pendkit.telemetry.log import readings_from_log

    folder = tempfile.mkdtemp()
    env = pendkit.make(fidelity="realistic", log_dir=folder)
    env.reset(seed=0, options={"start": "rest", "pendulum_angle_rad": 0.5})
    for _ in range(200):
        env.step(0)
    env.close()
    readings = readings_from_log(str(Path(folder) / "episode-0001.jsonl"))
    times = readings.millis / 1000
    angles = (encoder.counts_to_rad(readings.position_counts) + math.pi) % (2 * math.pi) - math.pi
    return times, angles, identify_free_swing(times, encoder.counts_to_rad(readings.position_counts))


def test_lab03_the_identified_frequency_is_half_a_percent_below_the_arm_locked_one(free_swing):
    fit = free_swing[2]
    assert round(100 * (fit.natural_frequency_rad_s / pendkit.RigParams().pendulum_natural_frequency_rad_s - 1),
                 1) == -0.5


def test_lab03_the_students_functions_drive_the_identification(free_swing):
    times, angles, fit = free_swing
    up = np.nonzero((angles[:-1] < 0) & (angles[1:] >= 0))[0]
    crossings = times[up] - angles[up] * (times[up + 1] - times[up]) / (angles[up + 1] - angles[up])
    period = float(np.mean(np.diff(crossings)))
    peaks = swing_peaks(times, angles)
    delta = float(np.mean(np.log(peaks[:-1] / peaks[1:])))
    zeta = delta / math.sqrt(4 * math.pi**2 + delta**2)
    assert len(yours_against_the_kit(period, zeta, fit)) == 1  # right: one line, no note
    assert len(yours_against_the_kit(period, zeta, fit, times, angles)) == 1
    at_samples = float(np.mean(np.diff(times[up + 1])))  # within the kit's error, yet not interpolated: named
    assert "not interpolated" in " ".join(yours_against_the_kit(at_samples, zeta, fit, times, angles))
    both = np.nonzero((angles[:-1] < 0) != (angles[1:] < 0))[0]
    assert "only upward crossings" in " ".join(yours_against_the_kit(float(np.mean(np.diff(times[both]))), zeta, fit))
    log10 = float(np.mean(np.log10(peaks[:-1] / peaks[1:])))
    assert "natural logarithm" in " ".join(yours_against_the_kit(period, log10 / math.sqrt(4 * math.pi**2), fit))


def test_lab05_the_wobble_switches_once_with_the_gap_and_11_times_without():
    t = np.arange(0.0, 3.0, 0.06)
    wobble = 0.95 - 0.1 * t + 0.12 * np.sin(2 * math.pi * t / 0.5)  # the lab's cell

    def switches(fall_rad):
        mode, modes = "swing", []
        for theta in wobble:
            if mode == "swing" and abs(theta) < 0.8:
                mode = "balance"
            elif mode == "balance" and abs(theta) > fall_rad:
                mode = "swing"
            modes.append(mode)
        return sum(a != b for a, b in zip(modes, modes[1:]))

    assert (switches(1.1), switches(0.8)) == (1, 11)


def test_lab05_overspin_in_rev_s_is_six_times_too_tight_for_a_swing_up():
    params = pendkit.RigParams()
    limit_rad_s = 2 * math.pi * params.overspin_limit_rev_s
    assert round(limit_rad_s / params.overspin_limit_rev_s) == 6 and round(limit_rad_s, 1) == 12.6
    # from hanging to upright the pendulum passes the bottom at 2 w0 (energy -1 to +1): far above 2 rad/s
    assert 2 * params.pendulum_natural_frequency_rad_s > 5 * params.overspin_limit_rev_s
