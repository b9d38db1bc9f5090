"""Hidden tests for lab 00 (instructor material: never copied into labs/)."""

import math

import numpy as np

from pendkit.grading import expect, task
from pendkit.grading.core import is_real, shown
from pendkit.grading.prelab import prelab_answers
from pendkit.grading.suites.lab00 import fraction_note, reward_note

reward = task("00.reward", function="reward", title="The paper's reward")
fraction = task("00.upright_fraction", function="upright_fraction", title="Fraction of time upright")


@reward.test(points=1, hidden=True, hint="20 random angles and velocities, each of either sign.")
def reward_is_symmetric(fn, rng):
    for theta, omega in rng.uniform(-3, 3, (20, 2)):
        expected = -theta**2 - 0.5 * (omega / (2 * math.pi)) ** 2
        got = fn(theta, omega)
        message = f"reward({theta:.3f}, {omega:.3f}) should be {expected:.4f}, got {shown(got)}"
        note = reward_note(theta, omega, got, mirrored=fn(-theta, -omega))
        expect(is_real(got) and abs(got - expected) < 1e-9, message + note)


@fraction.test(points=1, hidden=True, hint="A list (not an array) of six angles, and a trace of seven zeros.")
def a_list_and_an_upright_trace(fn, rng):
    angles = [0.1, -0.25, 0.31, -0.5, 2.0, -3.1]  # away from the bound: the_bound_is_strict has it
    got = fn(angles)
    note = fraction_note(angles, got)
    if not note and is_real(got) and abs(got - float(np.mean(np.asarray(angles) < 0.3))) < 1e-9:
        note = ": the negative angles all counted as upright; use the absolute value"
    expect(is_real(got) and abs(got - 1 / 3) < 1e-9,
           f"upright_fraction({angles}) should be 1/3, got {shown(got)}{note}", hint=not note)
    got = fn(np.zeros(7))
    expect(is_real(got) and abs(got - 1.0) < 1e-9, f"a trace of seven zeros (all upright) should give 1.0, got "
           f"{shown(got)}{fraction_note(np.zeros(7), got)}")


prelab_answers("00", {"steps_per_second": 16.666667, "episode_seconds": 30.0}, how={
    "steps_per_second": "a step is 60 ms = 0.06 s, so steps per second = 1 / 0.06 ≈ 16.7 (1/60 takes the ms "
                        "for seconds)",
    "episode_seconds": "500 steps of 0.06 s each: 500 × 0.06 = 30 s"})


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
     {"fraction_of_steps", "the_bound_is_strict", "a_list_and_an_upright_trace"}),
    ("00.upright_fraction", lambda angles: int(np.sum(np.abs(np.asarray(angles)) < 0.3)), "count"),
    ("00.upright_fraction", lambda angles: 100 * float(np.mean(np.abs(np.asarray(angles)) < 0.3)), "percentage"),
    ("00.upright_fraction", lambda angles: float(np.mean(np.abs(np.asarray(angles)) <= 0.3)), "the bound is strict",
     {"the_bound_is_strict"}),
    ("00.upright_fraction", lambda angles: float(np.mean(np.asarray(angles) <= 0.3)), "absolute value and a strict",
     {"the_bound_is_strict"}),
    ("00.reward", lambda theta, omega: -theta**2 - 0.5 * (omega * 2 * math.pi) ** 2, "multiplied by 2 pi",
     {"reward_values", "reward_is_symmetric"}),
    ("00.upright_fraction", lambda angles: float(np.sum(np.abs(np.asarray(angles)) < 0.3) / (len(angles) - 1)),
     "divided by len - 1",
     {"fraction_of_steps", "random_traces", "the_bound_is_strict", "a_list_and_an_upright_trace"}),
]
