"""Hidden tests for lab 09 (instructor material: never copied into labs/)."""

import math

import numpy as np

from pendkit.episode import time_to_upright_s
from pendkit.grading import expect, task
from pendkit.grading.core import Diagnosis, is_real, shown
from pendkit.grading.prelab import prelab_answers
from pendkit.grading.suites.lab09 import ARM_LIMIT_RAD, SPIN_LIMIT_RAD_S, STALE_AFTER_S, balance_note, cost_note

upright = task("09.time_to_upright_s", function="time_to_upright_s", title="Time to upright from a run")
balance = task("09.balance_error_deg", function="balance_error_deg", title="Balance error once upright")
watchdog = task("09.should_stop", function="should_stop", title="The safety watchdog")
matching = task("09.matching_cost", function="matching_cost", title="The trajectory-matching cost")


def random_run(rng, settles: bool):
    """A swing-up: large angles, a few near misses, then (if it `settles`) a long upright tail."""
    swing = rng.uniform(0.5, math.pi, rng.integers(5, 30)) * rng.choice([-1, 1], 1)
    near = rng.uniform(0.0, 0.6, rng.integers(0, 8)) * rng.choice([-1, 1], 1)
    tail = rng.uniform(-0.25, 0.25, rng.integers(5, 40)) if settles else rng.uniform(0.35, 2.0, 3)
    return np.concatenate([swing, near, tail])


def final_run_start(angles) -> int | None:
    """Index where the final upright stretch begins (the kit's own definition), None if the end is not upright."""
    start = time_to_upright_s(angles, 1.0)
    return None if start is None else int(start)


@upright.test(points=1, hidden=True, hint="Random swing-ups, with any step time.")
def random_swing_ups(fn, rng):
    for _ in range(6):
        angles, dt = random_run(rng, settles=bool(rng.integers(0, 2))), float(rng.choice([0.02, 0.05, 0.06]))
        start = final_run_start(angles)
        got = fn(angles, dt)
        expected = None if start is None else start * dt
        ok = got is None if expected is None else got is not None and abs(got - expected) < 1e-9
        said = ""
        if not ok and expected is not None and got is not None and is_real(got):
            steps = round((float(got) - expected) / dt, 6)
            said = {-1.0: Diagnosis(": one step early, at the last step outside 0.3 rad"),
                    1.0: Diagnosis(": one step late, the stretch's second step")}.get(steps, "")
            if not said and abs(float(got) - first_upright_entry(angles, dt)) < 1e-9:
                said = Diagnosis(": that is the first step inside 0.3 rad, but the pendulum left the band again "
                                 "after it; only the final run counts")
        expect(ok, f"a random run of {len(angles)} steps at {dt} s: expected {shown(expected)}, got {shown(got)}"
               + said)


@balance.test(points=1, hidden=True, hint="Random swing-ups, and one whose upright stretch starts at 0.66 s.")
def random_balance_tails(fn, rng):
    # the stretch from step 11: 0.66 / 0.06 is 10.999... in floats, so int() of the time lands a step early
    angles = np.radians([180, 150, 100, 60, 30, 25, 40, 20, 25, 35, 18, 4, -3, 4, -2, 3])
    expected = float(np.degrees(np.sqrt(np.mean(angles[11:] ** 2))))
    got = fn(angles, 0.06)
    note = balance_note(got, angles, 11)
    if got is not None and is_real(got) and abs(float(got) - np.degrees(np.sqrt(np.mean(angles[10:] ** 2)))) < 1e-6:
        note = Diagnosis(": the stretch starts one step early, at step 10 (if you turned the time into a step with "
                         "int(): 0.66 / 0.06 is 10.999... in floats, so round() it)")
    expect(got is not None and abs(got - expected) < 1e-6,
           f"a run upright from step 11 (0.66 s at 0.06 s): expected {shown(expected)}, got {shown(got)}" + note)
    for _ in range(6):
        angles = random_run(rng, settles=bool(rng.integers(0, 2)))
        start = final_run_start(angles)
        got = fn(angles, 0.06)
        expected = None if start is None else float(np.degrees(np.sqrt(np.mean(angles[start:] ** 2))))
        ok = got is None if expected is None else got is not None and abs(got - expected) < 1e-6
        note = "" if start is None else balance_note(got, angles, start)
        expect(ok, f"a random run of {len(angles)} steps: expected {shown(expected)}, got {shown(got)}" + note)


@watchdog.test(points=1, hidden=True, hint="Right at and just past each limit, and for readings that never came.")
def at_the_limits(fn, rng):
    eps = 1e-3
    cases = [((ARM_LIMIT_RAD - eps, 0.0, 0.0), False), ((ARM_LIMIT_RAD + eps, 0.0, 0.0), True),
             ((0.0, SPIN_LIMIT_RAD_S - eps, 0.0), False), ((0.0, -SPIN_LIMIT_RAD_S - eps, 0.0), True),
             ((0.0, 0.0, STALE_AFTER_S - eps), False), ((0.0, 0.0, STALE_AFTER_S + eps), True),
             ((0.0, 0.0, float("inf")), True), ((float("nan"), 0.0, 0.0), True), ((0.0, 0.0, float("nan")), True)]
    for _ in range(4):
        arm, rate = rng.uniform(-ARM_LIMIT_RAD, ARM_LIMIT_RAD) * 0.99, rng.uniform(-1, 1) * SPIN_LIMIT_RAD_S * 0.99
        cases.append(((arm, rate, rng.uniform(0, STALE_AFTER_S * 0.99)), False))
    for args, stop in cases:
        got = fn(*args)
        message = (f"should_stop{tuple(round(a, 4) for a in args)} should {'stop' if stop else 'return None'}, "
                   f"got {shown(got)}")
        if any(a != a for a in args):  # every comparison with NaN is False: a test for unsafe lets it through
            message = Diagnosis(message + ": a value that is not a number must stop the rig (test for safe, not "
                                          "unsafe)")
        expect(bool(got) == stop and (got is None or isinstance(got, str)), message)


@matching.test(points=1, hidden=True, hint="Random swings that cross the wrap, of any length.")
def random_swings(fn, rng):
    for _ in range(6):
        n = int(rng.integers(5, 200))
        recorded = np.mod(rng.uniform(-1.5, 1.5) * np.sin(np.linspace(0, rng.uniform(3, 20), n)), 2 * math.pi)
        simulated = np.mod(recorded + rng.normal(0, rng.uniform(0.01, 0.8), n), 2 * math.pi)
        gap = np.angle(np.exp(1j * (simulated - recorded)))
        expected = float(np.mean(gap ** 2))
        got = fn(simulated.copy(), recorded.copy())
        if got is not None and abs(float(got) - expected) < 1e-9 * max(1.0, expected):
            continue
        unwrapped = float(np.mean((simulated - recorded) ** 2))
        note = (Diagnosis(": the gaps were not wrapped into [-pi, pi); across the wrap at the bottom two nearly "
                          "equal readings are almost 2 pi apart") if got is not None and abs(float(got) - unwrapped)
                < 1e-9 * max(1.0, unwrapped) else cost_note(fn))
        expect(False, f"{n} steps of a random swing: expected {expected:.6g}, got {shown(got)}" + note)


prelab_answers("09", {"speed_ratio": 1.4, "stale_steps": 5.0, "growth_before_stop": 4.4817},
               where="Each question gives its numbers: a ratio of times, a count of steps, and e to the pole "
                     "times the wait.")


# --- The answer key (tests/grading/test_wrong_answers.py grades each through the tests above): a correct
# answer per task, which gets full marks, and plausible mistakes, each with words its feedback must contain.


def final_upright_start(angles, dt):
    return time_to_upright_s(angles, dt)


def first_upright_entry(angles, dt):
    inside = np.nonzero(np.abs(np.asarray(angles, dtype=float)) < 0.3)[0]
    return None if final_upright_start(angles, dt) is None else float(inside[0] * dt)


def balance_error_deg(angles, dt, rms=True, whole_run=False, early=0, by_int=False):
    start = final_upright_start(angles, dt)
    if start is None:
        return None
    step = int(start / dt) if by_int else int(round(start / dt))
    tail = np.asarray(angles, dtype=float)[0 if whole_run else max(step - early, 0):]
    return float(np.degrees(np.sqrt(np.mean(tail**2)) if rms else np.mean(tail)))


def should_stop(arm, rate, age):
    if not abs(arm) <= 1.6:
        return "arm"
    if not abs(rate) <= 20.0:
        return "spin"
    return None if age <= 0.3 else "stale"


CORRECT = {
    "09.time_to_upright_s": lambda angles, dt: final_upright_start(angles, dt),
    "09.balance_error_deg": lambda angles, dt: balance_error_deg(angles, dt),
    "09.should_stop": lambda arm, rate, age: should_stop(arm, rate, age),
    "09.matching_cost": lambda sim, rec: float(np.mean(((np.asarray(sim) - rec + np.pi) % (2 * np.pi) - np.pi) ** 2)),
}

MISTAKES = [
    ("09.time_to_upright_s", lambda a, dt: first_upright_entry(a, dt), "only the final run counts",
     {"the_final_upright_run", "random_swing_ups"}),
    ("09.matching_cost", lambda sim, rec: float(np.mean((np.asarray(sim) - rec + np.pi) % (2 * np.pi) - np.pi) ** 2),
     "cancelled"),
    ("09.matching_cost", lambda sim, rec: float(np.mean(((np.asarray(sim) - rec) % (2 * np.pi)) ** 2)),
     "not [0, 2 pi)", {"gaps_either_way_add_up", "the_wrap_at_the_bottom"}),
    ("09.time_to_upright_s", lambda a, dt: final_upright_start(np.abs(np.maximum(a, 0.0)), dt), "compare |angle|"),
    ("09.time_to_upright_s", lambda a, dt: None if final_upright_start(a, dt) is None
     else round(final_upright_start(a, dt) / dt), "step index"),
    ("09.time_to_upright_s", lambda a, dt: None if final_upright_start(a, dt) is None
     else max(final_upright_start(a, dt) - dt, 0.0), "one step early",
     {"random_swing_ups", "the_final_upright_run"}),
    ("09.time_to_upright_s", lambda a, dt: None if final_upright_start(a, dt) is None
     else final_upright_start(a, dt) + dt, "one step late", {"random_swing_ups", "the_final_upright_run",
                                                             "never_or_always"}),
    ("09.balance_error_deg", lambda a, dt: balance_error_deg(a, dt, rms=False), "mean"),
    ("09.balance_error_deg", lambda a, dt: balance_error_deg(a, dt, whole_run=True), "over the whole run",
     {"rms_over_the_final_run", "random_balance_tails"}),
    ("09.balance_error_deg", lambda a, dt: balance_error_deg(a, dt, early=1), "starts one step early",
     {"rms_over_the_final_run", "random_balance_tails"}),
    ("09.balance_error_deg", lambda a, dt: balance_error_deg(a, dt, by_int=True), "round() it",
     {"random_balance_tails"}),
    ("09.matching_cost", lambda sim, rec: CORRECT["09.matching_cost"](sim, rec) ** 0.5, "leave out the square root",
     {"a_mean_of_squares", "gaps_either_way_add_up", "the_wrap_at_the_bottom", "random_swings"}),
    ("09.matching_cost", lambda sim, rec: float(np.mean(np.abs((np.asarray(sim) - rec + np.pi) % (2 * np.pi) - np.pi))),
     "square the differences", {"a_mean_of_squares", "gaps_either_way_add_up", "the_wrap_at_the_bottom"}),
    ("09.matching_cost", lambda sim, rec: float(np.mean((np.asarray(sim) - rec) ** 2)), "wrap",
     {"the_wrap_at_the_bottom", "random_swings"}),
    ("09.balance_error_deg", lambda a, dt: None if balance_error_deg(a, dt) is None
     else math.radians(balance_error_deg(a, dt)), "radians"),
    ("09.should_stop", lambda arm, rate, age: "arm" if abs(arm) > 1.6 or abs(rate) > 20 or age > 0.3 else None,
     "not a number"),
    ("09.should_stop", lambda arm, rate, age: "arm" if arm > 1.6 or rate > 20 or not age <= 0.3 else None,
     "either way"),
    # the limits tested for safe, the age for unsafe: a NaN age goes on (a twentieth walk-through's slip)
    ("09.should_stop", lambda arm, rate, age: "arm" if not abs(arm) <= 1.6 or not abs(rate) <= 20 or age > 0.3
     else None, "age that is not a number", {"each_limit_stops_the_rig"}),
]
