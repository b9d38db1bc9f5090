"""Lab 05, energy swing-up: public tests."""

from __future__ import annotations

import math

from pendkit.grading.core import as_number, expect, task
from pendkit.grading.prelab import prelab_task
from pendkit.grading.written import written

energy = task("05.pendulum_energy", function="pendulum_energy", title="Normalised pendulum energy")
direction = task("05.pumping_direction", function="pumping_direction", title="Which way to accelerate the arm")
switch = task("05.next_mode", function="next_mode", title="Hand-over between swing-up and LQR")

W0 = 5.3


@energy.test(points=2, hint="e = 0.5 (omega / w0)^2 - cos(alpha), alpha from the bottom: -1 hanging, +1 upright.")
def hanging_upright_and_moving(fn, rng):
    for alpha, omega, expected in [(0.0, 0.0, -1.0), (math.pi, 0.0, 1.0), (math.pi / 2, 0.0, 0.0),
                                   (0.0, 2 * W0, 1.0), (0.3, -4.0, 0.5 * (4.0 / W0) ** 2 - math.cos(0.3))]:
        call = f"pendulum_energy({alpha:.3f}, {omega}, {W0})"
        got = as_number(fn(alpha, omega, W0), call)
        message = f"{call} should be {expected:.4f}, got {got:.4f}"
        if abs(got + expected) < 1e-9 and expected:
            message += ": the sign is flipped; measure alpha from the bottom, so hanging still is -1"
        elif abs(got - ((omega / W0) ** 2 - math.cos(alpha))) < 1e-9 and omega:
            message += ": kinetic energy has a factor 1/2"
        elif abs(got - (0.5 * omega**2 - math.cos(alpha))) < 1e-9 and omega:
            message += ": divide the rate by the natural frequency, so both terms are in units of m g l"
        expect(abs(got - expected) < 1e-9, message)


@direction.test(points=3, hint="de/dt is proportional to -cos(alpha) alpha' phi'': accelerate against "
                               "sign(alpha' cos(alpha)).")
def against_velocity_times_cosine(fn, rng):
    cases = [(0.2, 3.0, -1), (0.2, -3.0, 1), (2.8, 3.0, 1), (2.8, -3.0, -1), (-0.5, 1.0, -1), (-2.5, 1.0, 1)]
    for alpha, omega, expected in cases:
        got = fn(alpha, omega)
        message = f"pumping_direction({alpha}, {omega}) should be {expected:+d}, got {got!r}"
        if got == -expected:
            if abs(alpha) > math.pi / 2:
                message += ": above horizontal cos(alpha) < 0 and the pumping direction reverses"
            else:
                message += ": that takes energy out; accelerate *against* alpha' cos(alpha)"
        expect(got == expected, message)


@switch.test(points=2, hint="Catch inside both thresholds; give up only beyond the (wider) fall angle.")
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
        expect(got == expected, f"next_mode({mode!r}, {theta}, {omega}) should be {expected!r} ({why}), "
               f"got {got!r}")


prelab_task("05", ("energy_hanging", "energy_upright", "energy_horizontal",))

written("05.reflection", "Reflection", points=2)
