"""Lab 00, the tour: public tests."""

from __future__ import annotations

import math

import numpy as np

from pendkit.grading.core import Diagnosis, expect, is_real, shown, task
from pendkit.grading.prelab import prelab_task
from pendkit.grading.written import written

reward_task = task("00.reward", function="reward", title="The paper's reward", hidden_points=1)
fraction_task = task("00.upright_fraction", function="upright_fraction",
                     title="Fraction of time upright", hidden_points=1)


@reward_task.test(points=2, hint="reward = -theta^2 - 0.5 * omega^2 with omega in revolutions per second.")
def reward_values(fn, rng):
    for theta, omega_rad_s in [(0.0, 0.0), (math.pi, 0.0), (0.3, 0.0), (0.0, 2 * math.pi), (-0.5, -math.pi)]:
        expected = -theta**2 - 0.5 * (omega_rad_s / (2 * math.pi)) ** 2
        got = fn(theta, omega_rad_s)
        message = f"reward({theta:.3f}, {omega_rad_s:.3f}) should be {expected:.4f}, got {to_4(got)}"
        if is_real(got) and abs(got - expected) < 1e-9:
            continue
        expect(False, message + reward_note(theta, omega_rad_s, got, mirrored=fn(-theta, -omega_rad_s)))


def to_4(value) -> str:
    """A student's number to 4 decimals, as the expected value beside it is shown (anything else as it is)."""
    return f"{float(value):.4f}" if is_real(value) else shown(value)


def reward_note(theta: float, omega_rad_s: float, got, mirrored=None) -> str:
    """The cause of a wrong reward, named from its value (a `Diagnosis`), or "". `mirrored`: the reward at
    (-theta, -omega), where the test has it."""
    if not is_real(got):
        return ""
    if omega_rad_s and abs(got - (-theta**2 - 0.5 * omega_rad_s**2)) < 1e-9:
        return Diagnosis(": the velocity arrives in rad/s; convert it to rev/s first (divide by 2 pi)")
    if omega_rad_s and abs(got - (-theta**2 - 0.5 * (omega_rad_s * 2 * math.pi) ** 2)) < 1e-9:
        return Diagnosis(": the velocity was multiplied by 2 pi; rad/s to rev/s divides by 2 pi")
    if is_real(mirrored) and abs(got - mirrored) > 1e-12:
        return Diagnosis(": it changes when both signs flip; both terms are squared, so the sign must not matter")
    if got > 0:
        return Diagnosis(": the reward is a penalty, never positive")
    return ""


@fraction_task.test(points=1, hint="Count steps with |angle| < 0.3 rad and divide by the number of steps.")
def fraction_of_steps(fn, rng):
    angles = np.array([0.0, 0.1, -0.2, 0.29, -0.31, 1.0, -3.0, 0.5])
    expected = 4 / 8
    got = fn(angles)
    message = f"upright_fraction({angles.tolist()}) should be {expected}, got {shown(got)}"
    note = fraction_note(angles, got) or (": use the absolute value: -3.0 rad is far from upright"
                                          if is_real(got) and abs(got - float(np.mean(angles < 0.3))) < 1e-9 else "")
    expect(is_real(got) and abs(float(got) - expected) < 1e-9, message + note, hint=not note)


def fraction_note(angles, got) -> str:
    """The cause of a wrong fraction of `angles`, named from its value: a count, a percentage, a division by
    one step too few (or "")."""
    angles = np.asarray(angles, dtype=float)
    count = float(np.sum(np.abs(angles) < 0.3))
    if not is_real(got) or len(angles) < 2:
        return ""
    if count and abs(got - count) < 1e-9:
        return ": that is a count; divide by the number of steps"
    if abs(got - count / (len(angles) - 1)) < 1e-9:
        return f": divided by len - 1 ({len(angles) - 1}); divide by the number of steps, {len(angles)}"
    return percent_note(count / len(angles), got)


def percent_note(expected: float, got) -> str:
    """Words for an answer 100 times too large: a percentage where the task asks for a fraction."""
    if is_real(got) and expected and abs(got - 100 * expected) < 1e-6:
        return ": that is a percentage; return a fraction between 0 and 1 (do not multiply by 100)"
    return ""


# Each pair: an angle on or just inside the bound, and one that must count the same way (beyond it, or at 0).
# Only the bound is scored here, in the student's own units (a count, a fraction): the other tests score those.
BOUNDARY_PAIRS = [(0.3, 0.5), (-0.3, -0.5), (0.2999, 0.0), (-0.2999, 0.0)]


@fraction_task.test(points=1, hint="An angle of exactly 0.3 rad (either sign) is not within the bound: |angle| < 0.3.")
def the_bound_is_strict(fn, rng):
    for angle, like in BOUNDARY_PAIRS:
        got, want = fn(np.array([angle, 1.0])), fn(np.array([like, 1.0]))  # arrays: lists are another test's
        if is_real(got) and is_real(want) and abs(got - want) < 1e-9:
            continue
        inside = abs(angle) < 0.3
        said = (f"upright_fraction([{angle}, 1.0]) gave {shown(got)} but upright_fraction([{like}, 1.0]) gave "
                f"{shown(want)}")
        if not inside and is_real(got) and is_real(want) and got > want:
            expect(False, said + Diagnosis(": |angle| = 0.3 counted as upright; the bound is strict (< 0.3, not "
                                           "<= 0.3)"))
        expect(False, f"{said}: {angle} rad {'is within' if inside else 'is on'} the bound, so it counts as {like} "
                      f"does ({'upright' if inside else 'not upright'})")


@fraction_task.test(points=1, hint="A trace of 200 random angles of either sign.")
def random_traces(fn, rng):
    angles = rng.uniform(-math.pi, math.pi, 200)
    expected = float(np.mean(np.abs(angles) < 0.3))
    got = fn(angles)
    note = fraction_note(angles, got)
    if is_real(got) and abs(got - float(np.mean(angles < 0.3))) < 1e-9:
        note = ": use the absolute value: the angles far below -0.3 rad counted as upright"
    expect(is_real(got) and abs(float(got) - expected) < 1e-9,
           f"for 200 random angles expected {shown(expected)}, got {shown(got)}{note}", hint=not note)


prelab_task("00", ("steps_per_second", "episode_seconds",))

written("00.reflection", "Reflection", points=2)
