"""Hidden tests for lab 00 (instructor material: never copied into labs/)."""

import math

import numpy as np

from pendkit.grading import Failed, expect, task
from pendkit.grading.core import Diagnosis, is_real, raised_name, shown
from pendkit.grading.prelab import prelab_answers
from pendkit.grading.suites.lab00 import to_4

reward = task("00.reward", function="reward", title="The paper's reward")
fraction = task("00.upright_fraction", function="upright_fraction", title="Fraction of time upright")


@reward.test(points=1, hidden=True, hint="A state and its mirror image (both signs flipped) earn the same reward, "
                                         "never above 0: 20 random states of either sign.")
def same_for_mirrored_states(fn, rng):
    # the values themselves are reward_values' to score (a units slip is symmetric and stays below 0): this test
    # scores only the symmetry and the sign
    for theta, omega in rng.uniform(-3, 3, (20, 2)):
        got, mirrored = fn(theta, omega), fn(-theta, -omega)
        expect(is_real(got) and is_real(mirrored), f"reward({theta:.3f}, {omega:.3f}) should be a number, got "
               f"{shown(got)} (and {shown(mirrored)} for both signs flipped)")
        if abs(got - mirrored) > 1e-9:
            expect(False, f"reward({theta:.3f}, {omega:.3f}) = {to_4(got)} but reward({-theta:.3f}, {-omega:.3f}) "
                   f"= {to_4(mirrored)}" + Diagnosis(": it changes when both signs flip; both terms are squared, so "
                                                     "the sign must not matter"))
        expect(got <= 0, f"reward({theta:.3f}, {omega:.3f}) = {to_4(got)}"
               + Diagnosis(": the reward is a penalty, never positive"))


@fraction.test(points=1, hidden=True, hint="A list of angles must give what the same angles as an array give.")
def a_list_like_an_array(fn, rng):
    # only lists are scored here: what the fraction is is the other tests' to score
    angles = [0.1, -0.25, 0.31, -0.5, 2.0, -3.1]
    try:
        got = fn(angles)
    except (TypeError, ValueError) as error:
        raise Failed(f"upright_fraction({angles}) raised {raised_name(error)} ({error}): the angles may come as a "
                     "list; np.asarray(angles) turns it into an array first", hint=False) from error
    want = fn(np.asarray(angles))
    expect(is_real(got) and is_real(want) and abs(got - want) < 1e-12,
           f"upright_fraction({angles}) gave {shown(got)} for a list and {shown(want)} for the same angles as an array"
           + Diagnosis(": the angles may come as a list; np.asarray(angles) turns it into an array first"))


prelab_answers("00", {"steps_per_second": 16.666667, "episode_seconds": 30.0}, how={
    "steps_per_second": "a step is 60 ms = 0.06 s, so steps per second = 1 / 0.06 ≈ 16.7 (1/60 takes the ms "
                        "for seconds)",
    "episode_seconds": "500 steps of 0.06 s each: 500 × 0.06 = 30 s (500 × 60 takes the ms for seconds)"})


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
     "the sign must not matter", {"same_for_mirrored_states"}),
    ("00.upright_fraction", lambda angles: float(np.mean(np.asarray(angles) < 0.3)), "absolute value",
     {"fraction_of_steps", "random_traces"}),
    ("00.upright_fraction", lambda angles: float((abs(angles) < 0.3).mean()), "np.asarray",
     {"a_list_like_an_array"}),
    ("00.upright_fraction", lambda angles: int(np.sum(np.abs(np.asarray(angles)) < 0.3)), "count"),
    ("00.upright_fraction", lambda angles: 100 * float(np.mean(np.abs(np.asarray(angles)) < 0.3)), "percentage"),
    ("00.upright_fraction", lambda angles: float(np.mean(np.abs(np.asarray(angles)) <= 0.3)), "the bound is strict",
     {"the_bound_is_strict"}),
    ("00.upright_fraction", lambda angles: float(np.mean(np.asarray(angles) <= 0.3)), "absolute value",
     {"fraction_of_steps", "random_traces"}),
    ("00.upright_fraction", lambda angles: float(np.mean(np.asarray(angles) <= 0.3)), "the bound is strict",
     {"the_bound_is_strict"}),
    ("00.reward", lambda theta, omega: -theta**2 - 0.5 * (omega * 2 * math.pi) ** 2, "multiplied by 2 pi",
     {"reward_values"}),
    ("00.upright_fraction", lambda angles: float(np.sum(np.abs(np.asarray(angles)) < 0.3) / (len(angles) - 1)),
     "divided by len - 1", {"fraction_of_steps", "random_traces"}),
]
