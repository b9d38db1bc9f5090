"""Lab 05, energy swing-up: public tests."""

from __future__ import annotations

import math

from pendkit.grading.core import Diagnosis, NotGradable, as_number, expect, is_sequence_of, outcomes, shown, task
from pendkit.grading.prelab import prelab_task
from pendkit.grading.written import written

energy = task("05.pendulum_energy", function="pendulum_energy", title="Normalised pendulum energy", hidden_points=1)
direction = task("05.pumping_direction", function="pumping_direction",
                 title="Which way to accelerate the arm", hidden_points=1)
switch = task("05.next_mode", function="next_mode", title="Hand-over between swing-up and LQR", hidden_points=1)
limits = task("05.path_limits", function="path_limits", title="Bounds along the swing-up plan", hidden_points=1)
catch = task("05.catch_set", function="catch_set", title="The catch set as bounds on the final state", hidden_points=1)
final_cost = task("05.terminal_cost", function="terminal_cost", title="The plan's terminal cost", hidden_points=1)

W0 = 5.3


@energy.test(points=2, hint="e = 0.5 (omega / w0)^2 - cos(alpha), alpha from the bottom: -1 hanging, +1 upright.")
def hanging_upright_and_moving(fn, rng):
    for alpha, omega, expected in [(0.0, 0.0, -1.0), (math.pi, 0.0, 1.0), (math.pi / 2, 0.0, 0.0),
                                   (0.0, 2 * W0, 1.0), (0.3, -4.0, 0.5 * (4.0 / W0) ** 2 - math.cos(0.3))]:
        call = f"pendulum_energy({alpha:.3f}, {omega}, {W0})"
        got = as_number(fn(alpha, omega, W0), call)
        expect(abs(got - expected) < 1e-9, f"{call} should be {expected:.4f}, got {got:.4f}"
               + energy_note(alpha, omega, W0, got))


def energy_note(alpha: float, omega: float, w0: float, got: float) -> str:
    """The cause of a wrong energy, named from its value (a `Diagnosis`), or ""."""
    expected = 0.5 * (omega / w0) ** 2 - math.cos(alpha)
    if abs(got - ((omega / w0) ** 2 - math.cos(alpha))) < 1e-9 and omega:
        return Diagnosis(": kinetic energy has a factor 1/2")
    if abs(got - (0.5 * omega**2 - math.cos(alpha))) < 1e-9 and omega:
        return Diagnosis(": divide the rate by the natural frequency, so both terms are in units of m g l")
    if abs(got - (0.5 * (omega / w0) ** 2 + math.cos(alpha))) < 1e-9 and math.cos(alpha):
        return Diagnosis(": the cosine's sign is flipped; measure alpha from the bottom, so hanging still is -1 "
                         "(e = ... - cos(alpha))")
    if abs(got + expected) < 1e-9 and expected:
        return Diagnosis(": the sign is flipped; measure alpha from the bottom, so hanging still is -1")
    return ""


MOVING_CASES = [(0.2, 3.0, -1), (0.2, -3.0, 1), (2.8, 3.0, 1), (2.8, -3.0, -1), (-0.5, 1.0, -1), (-2.5, 1.0, 1)]


@direction.test(points=2, hint="de/dt is proportional to -cos(alpha) alpha' phi'': accelerate against "
                               "sign(alpha' cos(alpha)).")
def against_velocity_times_cosine(fn, rng):
    for alpha, omega, expected in MOVING_CASES:
        got = fn(alpha, omega)
        message = f"pumping_direction({alpha}, {omega}) should be {expected:+d}, got {shown(got)}"
        if got == -expected:
            if abs(alpha) > math.pi / 2:
                message += Diagnosis(": above horizontal cos(alpha) < 0 and the pumping direction reverses")
            else:
                message += Diagnosis(": that takes energy out; accelerate *against* alpha' cos(alpha)")
        expect(got == expected, message)


# where alpha' cos(alpha) is 0 the lab asks for +1: hanging still, and its own example exactly horizontal
NO_PUSH_CASES = (("pumping_direction(0.0, 0.0)", 0.0, 0.0), ("pumping_direction(math.pi / 2, 3.0)", math.pi / 2, 3.0))


@direction.test(points=1, hint="Where alpha' cos(alpha) = 0 (at rest, or exactly horizontal) return +1; treat "
                               "|alpha' cos(alpha)| below 1e-9 as 0.")
def plus_one_where_no_push_adds_energy(fn, rng):
    answers = outcomes(fn, [(alpha, omega) for alpha, omega, _ in MOVING_CASES])
    if any(outcome.error or outcome.value != expected for outcome, (_, _, expected) in zip(answers, MOVING_CASES)):
        raise NotGradable("pumping_direction does not yet answer as the rule does where the pendulum moves (see "
                          "against_velocity_times_cosine): this test then checks where alpha' cos(alpha) = 0")
    for call, alpha, omega in NO_PUSH_CASES:
        got = fn(alpha, omega)
        expect(got == 1, f"{call} should be +1, got {shown(got)}" + no_push_note(alpha, omega, got))


def no_push_note(alpha: float, omega: float, got) -> str:
    """Why a rule gave `got`, not the lab's +1, where alpha' cos(alpha) is 0 (at rest or exactly horizontal)."""
    where = "at rest" if omega == 0 else "exactly horizontal"
    note = (f": {where} alpha' cos(alpha) = 0 and no push adds energy; the lab asks for +1 there, so that a "
            "pendulum hanging still gets a first push")
    if got == 0:
        note += " (np.sign, or a product's sign, gives 0 there: return +1 instead)"
    elif omega and got == -1:  # said only of a rule right wherever the pendulum moves: it takes the product
        note += (f"; math.cos({alpha:.4f}) is {math.cos(alpha):.0e}, not 0, so treat |alpha' cos(alpha)| below "
                 "1e-9 as 0")
    return Diagnosis(note)


def pumping_note(calls: list[tuple[float, float]], answers: list) -> str:
    """What a pumping rule that gave `answers` to `calls` (alpha, omega) got wrong, when every answer shows it."""
    # at rest and exactly horizontal (cos(pi/2) is 6e-17, not 0) the lab's +1 is a convention, not the rule
    moving = [(alpha, omega, got) for (alpha, omega), got in zip(calls, answers)
              if abs(omega * math.cos(alpha)) > 1e-9]
    if moving and all(got == (1 if omega * math.cos(alpha) > 0 else -1) for alpha, omega, got in moving):
        return Diagnosis(": the sign is flipped in every quadrant: that brakes the swing, taking energy out; "
                         "accelerate *against* alpha' cos(alpha)")
    if moving and all(got == (-1 if omega > 0 else 1) for alpha, omega, got in moving):
        return Diagnosis(": right below horizontal, wrong above it: there cos(alpha) < 0 and the pumping "
                         "direction reverses")
    return ""


@switch.test(points=1, hint="Catch inside both thresholds; give up only beyond the (wider) fall angle.")
def hand_over_with_hysteresis(fn, rng):
    cases = [
        ("swing", 0.2, 1.0, "balance", "near upright and slow: catch it"),
        ("swing", 0.2, 9.0, "swing", "near upright but fast: it would fly through"),
        ("swing", 1.0, 0.0, "swing", "still far from upright"),
        ("balance", 1.0, 0.0, "balance", "between the catch and fall angles: keep balancing (hysteresis)"),
        ("balance", -1.3, 0.0, "swing", "beyond the fall angle: swing up again"),
    ]
    for mode, theta, omega, expected, why in cases:
        got = fn(mode, theta, omega)
        expect(got == expected, f"next_mode({shown(mode)}, {theta}, {omega}) should be {shown(expected)} ({why}), "
               f"got {shown(got)}")


CATCH_ANGLE_RAD, CATCH_VELOCITY_RAD_S, FALL_ANGLE_RAD = 0.8, 5.0, 1.1  # the lab's constants
# each threshold: its name, the comparison, the mode, and (angle, rate) exactly on it, just inside, just outside;
# the mode expected on and inside it, and outside it
THRESHOLDS = [
    ("CATCH_ANGLE_RAD", "|angle| < CATCH_ANGLE_RAD", "swing",
     ((CATCH_ANGLE_RAD, 1.0), (CATCH_ANGLE_RAD - 0.01, 1.0), (CATCH_ANGLE_RAD + 0.01, 1.0)),
     ("swing", "balance", "swing")),
    ("CATCH_VELOCITY_RAD_S", "|velocity| < CATCH_VELOCITY_RAD_S", "swing",
     ((0.2, CATCH_VELOCITY_RAD_S), (0.2, CATCH_VELOCITY_RAD_S - 0.1), (0.2, CATCH_VELOCITY_RAD_S + 0.1)),
     ("swing", "balance", "swing")),
    ("FALL_ANGLE_RAD", "|angle| > FALL_ANGLE_RAD", "balance",
     ((-FALL_ANGLE_RAD, 0.0), (-FALL_ANGLE_RAD + 0.01, 0.0), (-FALL_ANGLE_RAD - 0.01, 0.0)),
     ("balance", "balance", "swing")),
]
WRAPPED_AGAIN = ("swing", 2 * math.pi + 0.2, 1.0)  # upright a turn on: only a next_mode that wraps catches it


@switch.test(points=1, hint="Exactly on a threshold the mode stays as it is: every comparison is strict.")
def on_a_threshold(fn, rng):
    calls = [(mode, *state) for _, _, mode, states, _ in THRESHOLDS for state in states] + [WRAPPED_AGAIN]
    got = [outcome.error or outcome.value for outcome in outcomes(fn, calls)]
    judged = 0
    for k, (name, rule, mode, states, (on, inside, outside)) in enumerate(THRESHOLDS):
        if got[3 * k + 1] != inside or got[3 * k + 2] != outside:
            continue  # wrong on either side too: hand_over_with_hysteresis says how; here only the threshold counts
        judged += 1
        angle, rate = states[0]
        expect(got[3 * k] == on, f"next_mode({shown(mode)}, {angle}, {rate}) should be {shown(on)}, got "
               f"{shown(got[3 * k])}" + threshold_note(name, rule, got[-1] == "balance"))
    if not judged:
        raise NotGradable("next_mode is not right just inside and just outside its thresholds yet (see "
                          "hand_over_with_hysteresis): this test then checks it exactly on each threshold")


def threshold_note(name: str, rule: str, wraps_again: bool) -> str:
    """Why a next_mode changed the mode exactly on a threshold, where the lab says it stays."""
    if wraps_again and name == "CATCH_ANGLE_RAD":
        return Diagnosis(f": exactly on {name} the mode stays (strict: {rule}). Your next_mode seems to wrap the "
                         "angle again; it arrives wrapped to [-pi, pi), and wrapping 0.8 again, (0.8 + pi) % (2 pi) "
                         "- pi, gives 0.7999999999999998, just inside: use the angle as it comes")
    return Diagnosis(f": exactly on {name} the mode stays: the lab's thresholds are strict ({rule}; < and >, not "
                     "<= and >=)")


@limits.test(points=1, hint="The over-spin limit is in revolutions per second; the plan's rates are in rad/s.")
def targets_and_rates(fn, rng):
    got = fn(1.4, 2.0)
    expect(is_sequence_of(got, 2), f"path_limits(1.4, 2.0) should return a pair, got {shown(got)}")
    target, rate = (as_number(x, "path_limits(1.4, 2.0)") for x in got)
    expect(abs(target - 1.4) < 1e-9, f"the target limit should be the arm limit 1.4 rad, got {target}")
    expect(abs(rate - 4 * math.pi) < 1e-9, f"2 rev/s is {4 * math.pi:.3f} rad/s, got {rate}" + rate_note(rate, 2.0))


def rate_note(rate: float, overspin_rev_s: float) -> str:
    """Words for a pendulum rate limit left in the wrong unit, or nothing."""
    if abs(rate - overspin_rev_s) < 1e-9:
        return Diagnosis(": the over-spin limit is left in rev/s; the plan's rates are in rad/s, so convert "
                         "revolutions to radians (one turn is 2 pi)")
    if abs(rate - 360 * overspin_rev_s) < 1e-6:
        return Diagnosis(": that is in degrees per second; the plan's rates are in rad/s (one turn is 2 pi)")
    return ""


def bounds_pair(got, call: str):
    expect(is_sequence_of(got, 2), f"{call} should return (lower, upper), got {type(got).__name__}")
    lower, upper = (list(x) if is_sequence_of(x, 4) else None for x in got)
    expect(lower is not None and upper is not None, f"{call}: lower and upper should have 4 bounds each")
    return [as_number(x, call) for x in lower], [as_number(x, call) for x in upper]


@catch.test(points=3, hint="A box around upright_rad for the pendulum (measured from the bottom), symmetric "
                           "bounds for the rates and the arm.")
def box_around_upright(fn, rng):
    for upright in (math.pi, -math.pi):
        call = f"catch_set({upright:.4f}, 0.25, 1.5, 0.9, 6.0)"
        lower, upper = bounds_pair(fn(upright, 0.25, 1.5, 0.9, 6.0), call)
        want_lower, want_upper = [-0.9, upright - 0.25, -6.0, -1.5], [0.9, upright + 0.25, 6.0, 1.5]
        message = f"{call} should be ({want_lower}, {want_upper}), got ({lower}, {upper})"
        expect(all(abs(a - b) < 1e-9 for a, b in zip(lower + upper, want_lower + want_upper)),
               message + catch_note(lower, upper, upright, 0.25, (want_lower, want_upper)))


CATCH_ORDER = "[arm angle, pendulum angle, arm rate, pendulum rate]"


def _reordered(got, want) -> bool:
    """Whether both lists of `got` hold the bounds of `want`'s, at least one of them in another order."""
    def same(x, y):
        return len(x) == len(y) and all(abs(a - b) < 1e-9 for a, b in zip(x, y))
    return all(same(sorted(g), sorted(w)) for g, w in zip(got, want)) and not all(same(g, w) for g, w in zip(got, want))


CATCH_ORDER = "[arm angle, pendulum angle, arm rate, pendulum rate]"


def _reordered(got, want) -> bool:
    """Whether both lists of `got` hold the bounds of `want`'s, at least one of them in another order."""
    def same(x, y):
        return len(x) == len(y) and all(abs(a - b) < 1e-9 for a, b in zip(x, y))
    return all(same(sorted(g), sorted(w)) for g, w in zip(got, want)) and not all(same(g, w) for g, w in zip(got, want))


def _same_entries(got: list[float], right: list[float]) -> bool:
    return sorted(got) != got and all(abs(a - b) < 1e-9 for a, b in zip(sorted(got), sorted(right))) \
        and any(abs(a - b) > 1e-9 for a, b in zip(got, right)) if len(got) == len(right) else False


def catch_note(lower: list[float], upper: list[float], upright: float, angle: float, want=None) -> str:
    """The cause of a wrong catch set, named from its bounds (and from the right ones, `want` = (lower, upper),
    when given: entries in another order), a `Diagnosis`, or ""."""
    if want is not None and _reordered((lower, upper), want):
        return Diagnosis(f": your bounds are the right ones in another order; each list is {CATCH_ORDER}, the "
                         "final state's order, not the order of catch_set's arguments")
    if abs(lower[1] + angle) < 1e-9 and abs(upper[1] - angle) < 1e-9:
        return Diagnosis(": the pendulum's box is around 0, which is hanging (the angle is from the bottom); "
                         "centre it on upright_rad")
    if lower[2] == 0 or lower[3] == 0:
        return Diagnosis(": rates can be negative too; bound them on both sides")
    return ""


@final_cost.test(points=2, hint="0.1 phi^2 + 10 (alpha - upright)^2 + 0.1 phi'^2 + alpha'^2; ignore the fifth entry.")
def distance_from_upright(fn, rng):
    for state, upright in [([0.0, math.pi, 0.0, 0.0, 0.7], math.pi), ([0.3, 2.9, 1.0, 0.5, 0.2], math.pi),
                           ([-0.2, -3.0, 0.0, -1.0, 0.0], -math.pi)]:
        arm, pendulum, arm_rate, pendulum_rate = state[:4]
        expected = 0.1 * arm**2 + 10 * (pendulum - upright) ** 2 + 0.1 * arm_rate**2 + pendulum_rate**2
        call = f"terminal_cost({state}, {upright:.4f})"
        got = as_number(fn(list(state), upright), call)
        expect(abs(got - expected) < 1e-9, f"{call} should be {expected:.4f}, got {got:.4f}"
               + cost_note(got, state, upright))


def cost_note(got: float, state, upright: float) -> str:
    """Words for a terminal cost that measures the pendulum from 0 rather than from upright, or that reads the
    state one entry late (state[1:5]), or nothing."""
    arm, pendulum, arm_rate, pendulum_rate = state[:4]
    from_zero = 0.1 * arm**2 + 10 * pendulum**2 + 0.1 * arm_rate**2 + pendulum_rate**2
    if abs(got - from_zero) < 1e-9 * max(1.0, from_zero):
        return Diagnosis(": measure the pendulum's error from upright_rad, not from 0")
    late = 0.1 * state[1] ** 2 + 10 * (state[2] - upright) ** 2 + 0.1 * state[3] ** 2 + state[4] ** 2
    if abs(got - late) < 1e-9 * max(1.0, late):
        return Diagnosis(": it read state[1:5], one entry late; the state is [arm, pendulum, arm rate, pendulum "
                         "rate, target], so the four terms are state[0] to state[3]")
    return ""


prelab_task("05", ("energy_bottom_fast", "energy_tilted_at_rest", "energy_horizontal_moving"))

written("05.reflection", "Reflection", points=3)
