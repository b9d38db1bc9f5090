"""Lab 09, deploy to a rig: public tests."""

from __future__ import annotations

import math

import numpy as np

from pendkit.grading.core import Diagnosis, Failed, as_number, expect, is_real, shown, task
from pendkit.grading.prelab import prelab_task
from pendkit.grading.written import written

upright = task("09.time_to_upright_s", function="time_to_upright_s",
               title="Time to upright from a run", hidden_points=1)
balance = task("09.balance_error_deg", function="balance_error_deg", title="Balance error once upright",
               hidden_points=1, kit_helpers={"time_to_upright_s": "pendkit.features:time_to_upright_s"})
watchdog = task("09.should_stop", function="should_stop", title="The safety watchdog", hidden_points=1)
matching = task("09.matching_cost", function="matching_cost", title="The trajectory-matching cost", hidden_points=1)
written("09.gap_report", "Sim-to-real report", points=6)
written("09.safety_checklist", "Safety checklist", points=4)

ARM_LIMIT_RAD, SPIN_LIMIT_RAD_S, STALE_AFTER_S = 1.6, 20.0, 0.3


def run_of(angles_deg, dt_s=0.06):
    return np.radians(np.asarray(angles_deg, dtype=float)), dt_s


def _optional_number(got, call: str):
    return None if got is None else as_number(got, call)


@upright.test(points=2, hint="The last time the pendulum was outside 0.3 rad ends the swing-up: the run that "
                             "follows must last to the end.")
def the_final_upright_run(fn, rng):
    swing = [180, 120, 40, 10, 25, 5, 2, 1, 0, 0]  # 25 deg is outside 0.3 rad (17 deg)
    angles, dt = run_of(swing)
    got = _optional_number(fn(angles, dt), "time_to_upright_s(angles, 0.06)")
    message = f"upright for good from step 5 (0.30 s), got {shown(got)}"
    if got is not None and abs(got - 0.18) < 1e-9:
        message += Diagnosis(": the pendulum left the upright band again at step 4; only the final run counts")
    elif got is not None and abs(got - 5) < 1e-9:
        message += ": that is a step index; multiply by the step time"
    elif got is not None and abs(got - 0.24) < 1e-9:
        message += Diagnosis(": one step early, at step 4, the last step outside 0.3 rad; the stretch starts at the "
                             "first step inside it")
    elif got is not None and abs(got - 0.36) < 1e-9:
        message += Diagnosis(": one step late, the stretch's second step")
    expect(got is not None and abs(got - 0.30) < 1e-9, message)
    mirrored, dt = run_of([-a for a in swing])  # the same swing-up from the other side
    got = _optional_number(fn(mirrored, dt), "time_to_upright_s(the same swing from the other side)")
    message = f"the same swing-up from the other side (negative angles) is upright from 0.30 s too, got {shown(got)}"
    if got is not None and abs(got) < 1e-9:
        message += ": angles from upright are signed (the pendulum comes up from either side); compare |angle|"
    expect(got is not None and abs(got - 0.30) < 1e-9, message)


@upright.test(points=1, hint="Upright from the first step is 0 s; not upright at the end is no time at all: None.")
def never_or_always(fn, rng):
    angles, dt = run_of([180, 150, 90, 30, 10, 40])
    got = fn(angles, dt)
    expect(got is None, f"a run that ends 40 deg from upright has no time to upright (None), got {shown(got)}")
    angles, dt = run_of([3, 2, 1, 0])
    got = _optional_number(fn(angles, dt), "time_to_upright_s")
    message = f"a run upright from the start is upright at 0 s, got {shown(got)}"
    if got is not None and abs(got - dt) < 1e-9:
        message += Diagnosis(": one step late; the first step (at 0 s) is already inside 0.3 rad")
    expect(got is not None and abs(got) < 1e-9, message)


@balance.test(points=2, hint="RMS over the final upright run only, in degrees.")
def rms_over_the_final_run(fn, rng):
    angles, dt = run_of([180, 90, 30, 4, -3, 4, -3])
    got = _optional_number(fn(angles, dt), "balance_error_deg(angles, 0.06)")
    expected = math.sqrt((16 + 9 + 16 + 9) / 4)
    message = f"the final upright run [4, -3, 4, -3] deg has an RMS error of {expected:.3f} deg, got {shown(got)}"
    message += balance_note(got, angles, 3)
    expect(got is not None and abs(got - expected) < 1e-6, message)
    angles, dt = run_of([0, 20, 60, 120])
    got = fn(angles, dt)
    expect(got is None, f"a run that ends fallen has no balance error (None), got {shown(got)}")


def balance_note(got, angles_rad, start: int) -> str:
    """The cause of a wrong balance error, when `got` is one of the known wrong ones (a `Diagnosis`), else ""."""
    if got is None or not is_real(got):
        return ""
    angles = np.asarray(angles_rad, dtype=float)
    tail = angles[start:]
    right = np.degrees(np.sqrt(np.mean(tail**2)))
    causes = [(np.degrees(np.sqrt(np.mean(angles**2))), ": that is the RMS over the whole run, swing-up included; "
               "the balance error is over the final upright stretch only (from where time_to_upright_s says it "
               "begins)"),
              (np.degrees(np.mean(tail)), ": that is the mean; square, average, then take the root"),
              (np.degrees(np.mean(np.abs(tail))), ": that is the mean of |angle|; square, average, then take the root"),
              (np.sqrt(np.mean(tail**2)), ": that is in radians; the lab wants degrees"),
              (np.degrees(np.sqrt(np.mean(tail[1:] ** 2))), ": the stretch starts one step late; it begins at the "
               "first step of the final upright stretch"),
              (np.degrees(np.sqrt(np.mean(angles[start - 1:] ** 2))) if start > 0 else math.nan,
               ": the stretch starts one step early, at the last step outside 0.3 rad (this test runs your "
               "balance_error_deg with the kit's time_to_upright_s, so the slip is in balance_error_deg itself)")]
    for wrong, cause in causes:
        if abs(float(got) - wrong) < 1e-6 * max(1.0, abs(wrong)) and abs(wrong - right) > 1e-9:
            return Diagnosis(cause)
    return ""


def _stops(fn, call, *args) -> bool:
    got = fn(*args)
    if got is not None and not isinstance(got, str):
        raise Failed(f"{call} should return None (safe) or a reason as text, got {type(got).__name__}")
    return bool(got)


@watchdog.test(points=1, hint="Safe means None; anything to stop for returns a short reason.")
def safe_states_go_on(fn, rng):
    for args in [(0.0, 0.0, 0.05), (1.5, -12.0, 0.25), (-1.59, 19.0, 0.0)]:
        call = f"should_stop{args}"
        expect(not _stops(fn, call, *args), f"{call} is inside every limit: it should return None")


@watchdog.test(points=2, hint="Each limit on its own stops the rig: the arm's angle either way, the pendulum's "
                              "rate either way, readings older than STALE_AFTER_S, and any of the three not a number.")
def each_limit_stops_the_rig(fn, rng):
    for args, what in [((1.65, 0.0, 0.05), "the arm past +1.6 rad"), ((-1.65, 0.0, 0.05), "the arm past -1.6 rad"),
                       ((0.0, 21.0, 0.05), "the pendulum turning at +21 rad/s"),
                       ((0.0, -21.0, 0.05), "the pendulum turning at -21 rad/s"),
                       ((0.0, 0.0, 0.5), "readings 0.5 s old (the link is failing)"),
                       ((float("nan"), 0.0, 0.05), "an arm angle that is not a number"),
                       ((0.0, float("nan"), 0.05), "a rate that is not a number"),
                       ((0.0, 0.0, float("nan")), "a reading's age that is not a number")]:
        call = f"should_stop{args}"
        message = f"{call}: {what} must stop the rig, got None"
        if "not a number" in what:  # every comparison with NaN is False: a test for unsafe lets it through
            message = Diagnosis(message + "; test each value for safe (`not x <= limit`), not for unsafe")
        expect(_stops(fn, call, *args), message)


def _cost(fn, simulated, recorded) -> float:
    call = f"matching_cost({len(simulated)} simulated angles, {len(recorded)} recorded)"
    return as_number(fn(np.asarray(simulated, dtype=float), np.asarray(recorded, dtype=float)), call)


@matching.test(points=1, hint="Equal trajectories cost nothing; a constant gap d costs d squared, whatever the "
                              "length (a mean, not a sum).")
def a_mean_of_squares(fn, rng):
    recorded = np.linspace(0.0, 1.0, 20)
    got = _cost(fn, recorded, recorded)
    expect(abs(got) < 1e-12, f"identical trajectories should cost 0, got {shown(got)}")
    got = _cost(fn, recorded + 0.1, recorded)
    message = f"a gap of 0.1 rad at every step should cost 0.01 rad^2, got {shown(got)}"
    if abs(got - 0.2) < 1e-9:
        message += Diagnosis(": that is a sum over the 20 steps; take the mean")
    else:
        message += cost_note(fn)
    expect(abs(got - 0.01) < 1e-9, message)
    longer = _cost(fn, np.linspace(0.0, 1.0, 80) + 0.1, np.linspace(0.0, 1.0, 80))
    expect(abs(longer - 0.01) < 1e-9, f"the same gap over 80 steps should still cost 0.01, got {shown(longer)}")


@matching.test(points=1, hint="Gaps either way count the same, and a small negative gap is small: square each "
                              "difference, wrapped into [-pi, pi).")
def gaps_either_way_add_up(fn, rng):
    recorded = np.zeros(10)
    simulated = np.array([0.2, -0.2] * 5)
    got = _cost(fn, simulated, recorded)
    message = f"gaps of +0.2 and -0.2 rad in turn should cost 0.04, got {shown(got)}"
    if got > 1.0:
        message += Diagnosis(": a gap of -0.2 rad came out near 2 pi (6.08 rad); wrap each difference into "
                             "[-pi, pi), not [0, 2 pi)")
    else:
        message += cost_note(fn)
    expect(abs(got - 0.04) < 1e-9, message)


@matching.test(points=2, hint="The encoder reads from the bottom in [0, 2 pi): 0.05 and 6.23 rad are 0.1 rad "
                              "apart, not 6.18. Wrap each difference into [-pi, pi) first.")
def the_wrap_at_the_bottom(fn, rng):
    recorded = np.array([0.05, 0.02, 2 * math.pi - 0.01, 2 * math.pi - 0.04])
    simulated = np.array([2 * math.pi - 0.05, 0.12, 0.09, 0.06])
    got = _cost(fn, simulated, recorded)
    message = f"every pair here is 0.1 rad apart across the wrap at the bottom: 0.01 rad^2 expected, got {shown(got)}"
    note = cost_note(fn)
    if got > 1.0 and not note:
        note = Diagnosis(": the pendulum swings through 0 = 2 pi all the time; wrap the difference")
    message += note
    expect(abs(got - 0.01) < 1e-9, message)


def cost_note(fn) -> str:
    """The cause of a wrong matching cost, from gaps that tell the known wrong costs apart (a `Diagnosis`), else
    "": gaps of +0.1 and -0.3 rad in turn, away from the wrap."""
    gaps = np.array([0.1, -0.3, 0.1, -0.3, 0.1])
    recorded = np.full(len(gaps), 1.0)
    try:
        got = float(fn(recorded + gaps, recorded.copy()))
    except Exception:  # noqa: BLE001 (the student's code: the test reports its own failure)
        return ""
    cancelled = ": the signed differences cancelled; square each difference before the mean"
    causes = [(math.sqrt(np.mean(gaps**2)), ": that is the root of the mean square (RMS); the cost is the mean "
               "square itself: leave out the square root"),
              (np.mean(np.abs(gaps)), ": that is the mean of |gap|; square the differences (the mean of gap^2)"),
              (np.mean(gaps) ** 2, cancelled), (np.mean(gaps), cancelled), (abs(np.mean(gaps)), cancelled),
              (np.sum(gaps**2), ": that is a sum over the steps; take the mean"),
              (np.mean(np.mod(gaps, 2 * math.pi) ** 2), ": each difference was wrapped into [0, 2 pi), so a gap of "
               "-0.3 rad reads 5.98; wrap into [-pi, pi), not [0, 2 pi)")]
    for wrong, cause in causes:
        if abs(got - wrong) < 1e-9:
            return Diagnosis(cause)
    return ""


prelab_task("09", ("speed_ratio", "stale_steps", "growth_before_stop"))
