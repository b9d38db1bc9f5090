"""Hidden tests for lab 00 (instructor material: never copied into labs/)."""

import math

import numpy as np

from pendkit.grading import expect, task
from pendkit.grading.core import is_real, shown
from pendkit.grading.prelab import prelab_answers
from pendkit.grading.suites.lab00 import percent_note

reward = task("00.reward", function="reward", title="The paper's reward")
fraction = task("00.upright_fraction", function="upright_fraction", title="Fraction of time upright")


@reward.test(points=1, hidden=True, hint="The reward must match the formula for any angle and velocity, of "
                                        "either sign.")
def reward_is_symmetric(fn, rng):
    for theta, omega in rng.uniform(-3, 3, (20, 2)):
        expected = -theta**2 - 0.5 * (omega / (2 * math.pi)) ** 2
        got = fn(theta, omega)
        message = f"reward({theta:.3f}, {omega:.3f}) should be {expected:.4f}, got {shown(got)}"
        if abs(got - (-theta**2 - 0.5 * omega**2)) < 1e-9:
            message += ": the velocity arrives in rad/s; convert it to rev/s first"
        elif abs(got - fn(-theta, -omega)) > 1e-12:
            message += ": it changes when both signs flip; both terms are squared, so the sign must not matter"
        expect(abs(got - expected) < 1e-9, message)


@fraction.test(points=1, hidden=True, hint="Accept lists as well as arrays; the bound is strict.")
def lists_and_the_boundary(fn, rng):
    angles = [0.3, -0.3, 0.2999, -0.1, -1.0, -2.5]  # each mistake below gives its own answer
    got = fn(angles)
    note = boundary_note(got)
    expect(is_real(got) and abs(got - 1 / 3) < 1e-9,
           f"upright_fraction({angles}) should be 1/3, got {shown(got)}{note}", hint=not note)
    expect(abs(float(fn(np.zeros(7))) - 1.0) < 1e-9, "all-upright traces should give 1.0")


def boundary_note(got) -> str:
    """The cause of a wrong answer for `lists_and_the_boundary`'s angles, named from its value (or "")."""
    causes = {2 / 3: ": |angle| = 0.3 counted as upright; the bound is strict (< 0.3, not <= 0.3)",
              5 / 6: ": the negative angles all counted as upright; use the absolute value",
              1.0: ": the negative angles and 0.3 itself counted as upright; use the absolute value and a "
                   "strict bound (< 0.3)",
              2.0: ": that is a count; divide by the number of steps"}
    for value, cause in causes.items():
        if is_real(got) and abs(got - value) < 1e-9:
            return cause
    return percent_note(1 / 3, got)


prelab_answers("00", {"steps_per_second": 16.666667, "episode_seconds": 30.0})


# --- The answer key (tests/grading/test_wrong_answers.py grades each through the tests above): a correct
# answer per task, which gets full marks, and plausible mistakes, each with words its feedback must contain.

CORRECT = {
    "00.reward": lambda theta, omega: -theta**2 - 0.5 * (omega / (2 * math.pi)) ** 2,
    "00.upright_fraction": lambda angles: float(np.mean(np.abs(np.asarray(angles)) < 0.3)),
}

MISTAKES = [
    ("00.reward", lambda theta, omega: -theta**2 - 0.5 * omega**2, "rev/s"),
    ("00.reward", lambda theta, omega: theta**2 + 0.5 * (omega / (2 * math.pi)) ** 2, "never positive"),
    ("00.reward", lambda theta, omega: -theta**2 - 0.5 * abs(omega / (2 * math.pi)), "should be"),
    ("00.reward", lambda theta, omega: -theta * abs(theta) - 0.5 * (omega / (2 * math.pi)) ** 2,
     "the sign must not matter"),
    ("00.upright_fraction", lambda angles: float(np.mean(np.asarray(angles) < 0.3)), "absolute value",
     {"fraction_of_steps", "lists_and_the_boundary"}),
    ("00.upright_fraction", lambda angles: int(np.sum(np.abs(np.asarray(angles)) < 0.3)), "count"),
    ("00.upright_fraction", lambda angles: 100 * float(np.mean(np.abs(np.asarray(angles)) < 0.3)), "percentage"),
    ("00.upright_fraction", lambda angles: float(np.mean(np.abs(np.asarray(angles)) <= 0.3)), "the bound is strict",
     {"lists_and_the_boundary"}),
    ("00.upright_fraction", lambda angles: float(np.mean(np.asarray(angles) <= 0.3)), "absolute value and a strict",
     {"lists_and_the_boundary"}),
]
