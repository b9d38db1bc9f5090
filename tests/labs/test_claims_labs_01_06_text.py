"""Labs 01-06: what each lab's text says its plots and printouts show is what the run shows (lab 01's one
seam crossing, lab 02's start-up mean and its two RMS figures, lab 03's fitted figures, lab 05's rigs)."""

import re

import numpy as np

from pendkit import encoder
from pendkit.labs.free_swing import swing_peaks
from pendkit.labs.velocity_view import ALPHA, notes
from pendkit.sim.lab_readings import firmware_estimate_error_rev_s, free_swing_readings
from tests.labs.free_swing_log import logged_free_swing


def test_lab01_the_spin_crosses_the_seam_once_near_half_a_second_then_swings_about_one_turn():
    readings = free_swing_readings(period_ms=25.0, duration_s=3.0, offset_counts=317)
    jumps = np.diff(readings.raw_counts.astype(int))
    crossings = np.flatnonzero(np.abs(jumps) > 512)
    assert len(crossings) == 1 and 0.4 < readings.times_ms[crossings[0] + 1] / 1000 < 0.6
    assert readings.raw_counts[crossings[0]] > 990 and readings.raw_counts[crossings[0] + 1] < 30
    # the top (half a turn past hanging's 317: raw 829) comes first, at about 0.33 s; the seam's jump is later
    rising = slice(0, np.argmax(readings.raw_counts >= 317 + 512) + 1)
    assert 320 < np.interp(829, readings.raw_counts[rising], readings.times_ms[rising]) < 340
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


def _free_swing(steps):
    import math

    from pendkit.control.sysid import identify_free_swing

    times, angles, readings = logged_free_swing(steps)
    up = np.nonzero((angles[:-1] < 0) & (angles[1:] >= 0))[0]
    crossings = times[up] - angles[up] * (times[up + 1] - times[up]) / (angles[up + 1] - angles[up])
    peaks = swing_peaks(times, angles)
    delta = float(np.mean(np.log(peaks[:-1] / peaks[1:])))
    zeta = delta / math.sqrt(4 * math.pi**2 + delta**2)
    yours = 2 * math.pi / float(np.mean(np.diff(crossings))) / math.sqrt(1 - zeta**2)  # as the lab prints it
    return yours, identify_free_swing(times, encoder.counts_to_rad(readings.position_counts))


def test_lab03_yours_and_the_kits_w0_agree_within_its_error_either_way_round():
    (short, fit), (long, same_fit) = _free_swing(200), _free_swing(300)  # ci's and the classroom's runs
    assert fit.natural_frequency_rad_s == same_fit.natural_frequency_rad_s  # the kit's fit does not move
    assert short < fit.natural_frequency_rad_s < long  # yours can land either side
    for yours in (short, long):
        assert abs(yours - fit.natural_frequency_rad_s) < 1.5 * fit.natural_frequency_se < 0.015


def test_lab03_the_slope_is_a_quarter_below_the_rated_speed_and_a_whole_step_fit_is_not_saved():
    import math

    from pendkit.control.sysid import identify_servo_steps
    from pendkit.rig import RigParams
    from pendkit.sim.lab_readings import servo_step_readings
    from pendkit.sim.servo_fit import match_servo_speed

    bench = servo_step_readings(steps_rad=(0.9,), hold_s=0.6, params=RigParams().replace(servo_speed_s_per_60deg=0.26),
                                start_rad=0.3)  # the lab's bench: a 0.6 rad step from 0.3 rad
    slope = identify_servo_steps(bench.times_s, bench.commanded_rad, bench.arm_rad).slew_rate_rad_s
    rated = math.radians(60) / 0.26
    assert round(slope, 1) == 2.9 and round(rated, 1) == 4.0 and 0.65 < slope / rated < 0.8
    assert round(match_servo_speed(slope, steps_rad=(0.6,)).servo_speed_s_per_60deg, 2) == 0.26
    whole_step = match_servo_speed(slope / 0.8, steps_rad=(0.6,)).servo_speed_s_per_60deg
    assert whole_step < 0.9 * RigParams().servo_speed_s_per_60deg  # the cell's "not saved" branch


def test_lab05_from_rest_the_slower_servos_third_swing_is_caught_and_the_datasheets_is_not():
    import math

    import pendkit
    from pendkit.control.swingup import SwingUpController
    from pendkit.episode import run_episode, time_to_upright_s

    for speed, fidelity, upright_at in [(0.20, "ideal", 4.02), (0.20, "realistic", 2.94), (0.26, "ideal", 1.80),
                                        (0.26, "realistic", 1.92)]:
        params = pendkit.RigParams().replace(servo_speed_s_per_60deg=speed)
        env = pendkit.make(action_mode="continuous", fidelity=fidelity, start="rest", filter_coefficient=0.0,
                           params=params)
        trace = run_episode(env, SwingUpController.for_env(env), seed=0, steps=250)
        assert round(time_to_upright_s(trace.pendulum_from_upright_rad, env.unwrapped.dt), 2) == upright_at
        if (speed, fidelity) == (0.20, "ideal"):  # the third swing's closest approach: about 16 deg short
            away = np.degrees(np.abs(np.asarray(trace.pendulum_from_upright_rad)))
            closest = [away[i] for i in range(1, len(away) - 1) if away[i - 1] > away[i] <= away[i + 1]]
            assert round(closest[2]) == 16 and closest[3] > 40, closest[:4]
    assert math.isclose(pendkit.RigParams().servo_speed_s_per_60deg, 0.20)
