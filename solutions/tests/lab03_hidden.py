"""Hidden tests for lab 03 (instructor material: never copied into labs/)."""

import math

import numpy as np

from pendkit.grading import expect, task
from pendkit.rig import RigParams
from pendkit.sim.sampling import free_swing_readings

frequency = task("03.natural_frequency", function="natural_frequency", title="Compound-pendulum frequency")
period = task("03.period_from_crossings", function="period_from_crossings", title="Period from zero crossings")
damping = task("03.damping_ratio", function="damping_ratio", title="Damping from successive peaks")


@frequency.test(points=1, hidden=True, hint="Check it against the rig's own numbers.")
def the_rigs_own_pendulum(fn, rng):
    p = RigParams()
    got = fn(p.pendulum_mass_kg, p.pendulum_com_from_pivot_m, p.pendulum_inertia_about_pivot_kg_m2)
    expect(abs(got - p.pendulum_natural_frequency_rad_s) < 1e-6, f"the rig's pendulum should give "
           f"{p.pendulum_natural_frequency_rad_s:.4f} rad/s, got {got!r}")


@period.test(points=1, hidden=True, hint="It must work on a real (twin) swing sampled every 25 ms.")
def a_twin_swing(fn, rng):
    readings = free_swing_readings(period_ms=25.0, duration_s=6.0, start_velocity_rad_s=1.0)
    angles = (readings.raw_counts * 2 * math.pi / 1024 + math.pi) % (2 * math.pi) - math.pi
    got = fn(readings.times_ms / 1000, angles)
    expected = 2 * math.pi / RigParams().pendulum_natural_frequency_rad_s
    expect(abs(got - expected) < 0.01, f"the twin's small swing has a period of about {expected:.3f} s, got {got!r}")


@damping.test(points=1, hidden=True, hint="Average the decrement over all cycles, not just the first.")
def noisy_peaks(fn, rng):
    zeta = 0.07
    delta = 2 * math.pi * zeta / math.sqrt(1 - zeta**2)
    peaks = 0.6 * np.exp(-delta * np.arange(8)) * (1 + 0.002 * rng.standard_normal(8))
    got = fn(peaks)
    expect(abs(got - zeta) < 0.003, f"slightly noisy peaks with zeta = 0.07 gave {got!r}")
