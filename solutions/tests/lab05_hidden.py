"""Hidden tests for lab 05 (instructor material: never copied into labs/)."""

import math

from pendkit.grading import expect, outcomes, task
from pendkit.grading.core import as_number, is_real, shown
from pendkit.grading.prelab import prelab_answers
from pendkit.grading.suites.lab05 import (
    bounds_pair,
    catch_note,
    cost_note,
    energy_note,
    pumping_note,
    rate_note,
)

energy = task("05.pendulum_energy", function="pendulum_energy", title="Normalised pendulum energy")
direction = task("05.pumping_direction", function="pumping_direction", title="Which way to accelerate the arm")


@energy.test(points=1, hidden=True, hint="Angles wound past a full turn, and a negative one, at rest.")
def wound_up_angles(fn, rng):
    for alpha in (2 * math.pi, 3 * math.pi, -math.pi / 3):
        expected = -math.cos(alpha)
        got = fn(alpha, 0.0, 5.3)
        note = energy_note(alpha, 0.0, 5.3, float(got)) if is_real(got) else ""
        expect(is_real(got) and abs(got - expected) < 1e-9,
               f"pendulum_energy({alpha:.3f}, 0, 5.3) should be {expected:.4f}, got {shown(got)}" + note)


@direction.test(points=1, hidden=True, hint="Every quadrant and both directions of swing.")
def all_quadrants(fn, rng):
    # at rest and exactly horizontal is the public plus_one_where_no_push_adds_energy's: one slip there costs that
    # test only
    calls = [(float(alpha), omega) for alpha in rng.uniform(-math.pi, math.pi, 40) for omega in (-2.0, 2.0)]
    results = outcomes(fn, calls)
    note = pumping_note(calls, [outcome.value for outcome in results])
    for (alpha, omega), outcome in zip(calls, results):
        expected = -1 if omega * math.cos(alpha) > 1e-9 else 1
        got = outcome.error or outcome.value
        expect(outcome.error is None and outcome.value == expected,
               f"pumping_direction({alpha:.4f}, {omega}) should be {expected:+d}, got {shown(got)}" + note)


switch = task("05.next_mode", function="next_mode", title="Hand-over between swing-up and LQR")
CATCH_ANGLE_RAD, CATCH_VELOCITY_RAD_S, FALL_ANGLE_RAD = 0.8, 5.0, 1.1  # the lab's constants


@switch.test(points=1, hidden=True, hint="Both modes, both signs, random states inside and outside every threshold.")
def random_states(fn, rng):
    # exactly on a threshold is the public on_a_threshold's: one slip there costs that test only
    calls = [(mode, float(theta), float(omega)) for mode in ("swing", "balance")
             for theta, omega in rng.uniform([-1.6, -8.0], [1.6, 8.0], (40, 2))]
    for (mode, theta, omega), outcome in zip(calls, outcomes(fn, calls)):
        if mode == "swing":
            want = "balance" if abs(theta) < CATCH_ANGLE_RAD and abs(omega) < CATCH_VELOCITY_RAD_S else "swing"
            why = ("within both catch thresholds: catch it" if want == "balance" else "outside the catch angle"
                   if abs(theta) >= CATCH_ANGLE_RAD else "near upright but too fast: it would fly through")
        else:
            want = "swing" if abs(theta) > FALL_ANGLE_RAD else "balance"
            why = ("beyond the fall angle: swing up again" if want == "swing" else "near upright: keep balancing"
                   if abs(theta) < CATCH_ANGLE_RAD else "between the catch and fall angles: keep balancing "
                   "(hysteresis)")
        expect(outcome.error is None and outcome.value == want,
               f"next_mode({shown(mode)}, {theta:.3f}, {omega:.3f}) should be {shown(want)} ({why}), "
               f"got {outcome.error or outcome.value!r}")


catch = task("05.catch_set", function="catch_set", title="The catch set as bounds on the final state")
final_cost = task("05.terminal_cost", function="terminal_cost", title="The plan's terminal cost")
limits = task("05.path_limits", function="path_limits", title="Bounds along the swing-up plan")


ENTRIES = ("arm angle", "pendulum angle", "arm rate", "pendulum rate")


@catch.test(points=1, hidden=True, hint="Random thresholds, upright at pi, -pi and 3 pi.")
def random_thresholds(fn, rng):
    for _ in range(10):
        upright = float(rng.choice([math.pi, -math.pi, 3 * math.pi]))
        angle, velocity, arm, arm_velocity = (float(v) for v in rng.uniform(0.05, 8.0, 4))
        call = f"catch_set({upright:.4f}, {angle:.3f}, {velocity:.3f}, {arm:.3f}, {arm_velocity:.3f})"
        lower, upper = bounds_pair(fn(upright, angle, velocity, arm, arm_velocity), call)
        want = ([-arm, upright - angle, -arm_velocity, -velocity], [arm, upright + angle, arm_velocity, velocity])
        wrong = [i for i in range(4) if abs(lower[i] - want[0][i]) > 1e-9 or abs(upper[i] - want[1][i]) > 1e-9]
        if wrong:
            i = wrong[0]
            expect(False, f"{call}: the {ENTRIES[i]} bounds should be ({want[0][i]:.4f}, {want[1][i]:.4f}), got "
                          f"({shown(lower[i])}, {shown(upper[i])})" + catch_note(lower, upper, upright, angle, want))


@final_cost.test(points=1, hidden=True, hint="Random states, both uprights; the fifth entry does not count.")
def random_states(fn, rng):
    for _ in range(20):
        state = [float(v) for v in rng.uniform(-4, 4, 5)]
        upright = float(rng.choice([math.pi, -math.pi]))
        expected = (0.1 * state[0] ** 2 + 10 * (state[1] - upright) ** 2 + 0.1 * state[2] ** 2 + state[3] ** 2)
        call = f"terminal_cost({[round(v, 4) for v in state]}, {upright:.4f})"
        got = as_number(fn(state, upright), call)
        expect(abs(got - expected) < 1e-9 * max(1.0, expected), f"{call} should be {expected:.4f}, got {got:.4f}"
               + cost_note(got, state, upright))


@limits.test(points=1, hidden=True, hint="Any arm limit and over-spin limit.")
def other_limits(fn, rng):
    for arm, overspin in rng.uniform([0.2, 0.5], [1.5, 5.0], (5, 2)):
        target, rate = (float(x) for x in fn(float(arm), float(overspin)))
        call = f"path_limits({arm:.3f}, {overspin:.3f})"
        expect(abs(target - arm) < 1e-9, f"{call}: the target limit should be the arm limit {arm:.3f} rad, got "
                                         f"{shown(target)}")
        expect(abs(rate - 2 * math.pi * overspin) < 1e-9, f"{call}: {overspin:.3f} rev/s is "
               f"{2 * math.pi * overspin:.3f} rad/s, got {shown(rate)}" + rate_note(rate, overspin))


prelab_answers("05", {"energy_bottom_fast": 1.0, "energy_tilted_at_rest": -0.5, "energy_horizontal_moving": 0.5},
               how={"energy_bottom_fast": "e = 0.5 (alpha' / w0)^2 - cos(alpha) = 0.5 × 2^2 - cos 0 = 2 - 1 = 1, "
                                          "upright's own energy: just enough",
                    "energy_tilted_at_rest": "at rest only -cos(alpha) is left: -cos(60 deg) = -0.5",
                    "energy_horizontal_moving": "e = 0.5 × 1^2 - cos(pi/2) = 0.5 - 0 = 0.5"})


# --- The answer key (tests/grading/test_wrong_answers.py grades each through the tests above): a correct
# answer per task, which gets full marks, and plausible mistakes, each with words its feedback must contain.


def catch_set(upright, angle, velocity, arm, arm_velocity, centre=None, one_sided=False):
    centre = upright if centre is None else centre
    low_rate = 0.0 if one_sided else 1.0
    return ([-arm, centre - angle, -low_rate * arm_velocity, -low_rate * velocity],
            [arm, centre + angle, arm_velocity, velocity])


def terminal_cost(x, upright):
    return 0.1 * x[0] ** 2 + 10 * (x[1] - upright) ** 2 + 0.1 * x[2] ** 2 + x[3] ** 2


def next_mode(mode, theta, w, catch=0.8, fall=1.1, check_velocity=True, strict=True, wrap=False):
    theta = (theta + math.pi) % (2 * math.pi) - math.pi if wrap else theta  # wrapped again: 0.8 -> 0.7999999999999998
    below, above = (float.__lt__, float.__gt__) if strict else (float.__le__, float.__ge__)
    if mode == "swing" and below(abs(theta), catch) and (below(abs(w), 5.0) or not check_velocity):
        return "balance"
    if mode == "balance" and above(abs(theta), fall):
        return "swing"
    return mode


def catch_set_in_argument_order(upright, angle, velocity, arm, arm_velocity):
    """The right bounds listed as catch_set's arguments come: pendulum first, then the arm."""
    lower, upper = catch_set(upright, angle, velocity, arm, arm_velocity)
    return [lower[i] for i in (1, 0, 3, 2)], [upper[i] for i in (1, 0, 3, 2)]


def pumping_direction_by_sign(alpha, w):
    """-sign(alpha' cos(alpha)) as np.sign gives it: 0 at rest, and exactly horizontal only where cos is 0."""
    product = w * math.cos(alpha)
    return -1 if product > 1e-9 else (1 if product < -1e-9 else 0)


def pumping_braking_by_the_convention(alpha, w):
    """Flipped everywhere, yet +1 where |alpha' cos(alpha)| < 1e-9 as the lab asks (exactly horizontal too)."""
    product = w * math.cos(alpha)
    return 1 if product > 1e-9 else (-1 if product < -1e-9 else 1)


CORRECT = {
    "05.pendulum_energy": lambda alpha, w, w0: 0.5 * (w / w0) ** 2 - math.cos(alpha),
    "05.pumping_direction": lambda alpha, w: -1 if w * math.cos(alpha) > 1e-9 else 1,
    "05.next_mode": lambda mode, theta, w: next_mode(mode, theta, w),
    "05.path_limits": lambda arm, rev_s: (arm, 2 * math.pi * rev_s),
    "05.catch_set": lambda up, a, w, arm, arm_w: catch_set(up, a, w, arm, arm_w),
    "05.terminal_cost": lambda x, up: terminal_cost(x, up),
}

MISTAKES = [
    ("05.pendulum_energy", lambda alpha, w, w0: 0.5 * (w / w0) ** 2 + math.cos(alpha), "sign is flipped"),
    ("05.pendulum_energy", lambda alpha, w, w0: (w / w0) ** 2 - math.cos(alpha), "factor 1/2"),
    ("05.pendulum_energy", lambda alpha, w, w0: 0.5 * w**2 - math.cos(alpha), "natural frequency"),
    ("05.pumping_direction", lambda alpha, w: 1 if w * math.cos(alpha) > 0 else -1, "brakes the swing",
     {"all_quadrants"}),
    ("05.pumping_direction", lambda alpha, w: -1 if w > 0 else 1, "above horizontal"),
    ("05.next_mode", lambda mode, theta, w: next_mode(mode, theta, w, fall=0.8), "hysteresis"),
    ("05.next_mode", lambda mode, theta, w: next_mode(mode, theta, w, check_velocity=False), "fly through"),
    ("05.path_limits", lambda arm, rev_s: (arm, rev_s), "left in rev/s", {"targets_and_rates", "other_limits"}),
    ("05.catch_set", lambda up, a, w, arm, arm_w: catch_set(up, a, w, arm, arm_w, one_sided=True), "both sides"),
    ("05.terminal_cost", lambda x, up: terminal_cost(x, 0.0), "not from 0", {"distance_from_upright", "random_states"}),
    ("05.terminal_cost", lambda x, up: terminal_cost(list(x)[1:5], up), "state[1:5]",
     {"distance_from_upright", "random_states"}),
    ("05.catch_set", lambda up, a, w, arm, arm_w: catch_set(up, a, w, arm, arm_w, centre=0.0), "around 0",
     {"box_around_upright", "random_thresholds"}),
    ("05.pendulum_energy", lambda alpha, w, w0: 0.5 * (w / w0) ** 2 + math.cos(alpha), "cosine's sign",
     {"hanging_upright_and_moving", "wound_up_angles"}),
    ("05.pumping_direction", pumping_braking_by_the_convention, "brakes the swing", {"all_quadrants"}),
    ("05.next_mode", lambda mode, theta, w: next_mode(mode, theta, w, strict=False), "strict", {"on_a_threshold"}),
    ("05.next_mode", lambda mode, theta, w: next_mode(mode, theta, w, wrap=True), "arrives wrapped",
     {"on_a_threshold"}),
    ("05.catch_set", catch_set_in_argument_order, "in another order", {"box_around_upright", "random_thresholds"}),
    # at rest and exactly horizontal: the public test's alone
    ("05.pumping_direction", pumping_direction_by_sign, "first push", {"plus_one_where_no_push_adds_energy"}),
    ("05.pumping_direction", lambda alpha, w: -1 if w * math.cos(alpha) > 0 else 1, "not 0",
     {"plus_one_where_no_push_adds_energy"}),
]
