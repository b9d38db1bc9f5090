"""Hidden tests for lab 05 (instructor material: never copied into labs/)."""

import math

from pendkit.grading import expect, outcomes, task
from pendkit.grading.prelab import prelab_answers

energy = task("05.pendulum_energy", function="pendulum_energy", title="Normalised pendulum energy")
direction = task("05.pumping_direction", function="pumping_direction", title="Which way to accelerate the arm")


@energy.test(points=1, hidden=True, hint="Angles past a full turn are the same pendulum position.")
def wound_up_angles(fn, rng):
    for alpha in (2 * math.pi, 3 * math.pi, -math.pi / 3):
        expected = -math.cos(alpha)
        got = fn(alpha, 0.0, 5.3)
        expect(abs(got - expected) < 1e-9, f"pendulum_energy({alpha:.3f}, 0, 5.3) should be {expected:.4f}")


@direction.test(points=1, hidden=True, hint="Check every quadrant and both directions of swing.")
def all_quadrants(fn, rng):
    calls = [(float(alpha), omega) for alpha in rng.uniform(-math.pi, math.pi, 40) for omega in (-2.0, 2.0)]
    for (alpha, omega), outcome in zip(calls, outcomes(fn, calls)):
        expected = -1 if omega * math.cos(alpha) > 0 else 1
        expect(outcome.error is None and outcome.value == expected, f"pumping_direction({alpha:.3f}, {omega}) is wrong")


switch = task("05.next_mode", function="next_mode", title="Hand-over between swing-up and LQR")
CATCH_ANGLE_RAD, CATCH_VELOCITY_RAD_S, FALL_ANGLE_RAD = 0.8, 5.0, 1.1  # the lab's constants


@switch.test(points=1, hidden=True, hint="Both modes, both signs, inside and outside every threshold.")
def random_states(fn, rng):
    calls = [(mode, float(theta), float(omega)) for mode in ("swing", "balance")
             for theta, omega in rng.uniform([-1.6, -8.0], [1.6, 8.0], (40, 2))]
    for (mode, theta, omega), outcome in zip(calls, outcomes(fn, calls)):
        if mode == "swing":
            want = "balance" if abs(theta) < CATCH_ANGLE_RAD and abs(omega) < CATCH_VELOCITY_RAD_S else "swing"
        else:
            want = "swing" if abs(theta) > FALL_ANGLE_RAD else "balance"
        expect(outcome.error is None and outcome.value == want,
               f"next_mode({mode!r}, {theta:.3f}, {omega:.3f}) should be {want!r}, "
               f"got {outcome.error or outcome.value!r}")


prelab_answers("05", {"energy_hanging": -1.0, "energy_upright": 1.0, "energy_horizontal": 0.0})
