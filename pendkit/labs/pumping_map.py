"""Lab 05: the student's pumping direction over the whole swing, beside the rule it should follow.

The swing-up controller asks the rule about a small swing a quarter period earlier (below the horizontal,
where cos(alpha) > 0), so a rule without cos(alpha) swings the twin up just as well: this map is where the
flip above the horizontal shows."""

from __future__ import annotations

import math

import numpy as np

ANGLES_RAD = np.linspace(-math.pi, math.pi, 73)
RATES_PER_W0 = np.linspace(-2.0, 2.0, 41)  # alpha' / w0: 2 is the rate of a swing that goes over the top


def right_direction(angle_from_bottom_rad: float, velocity_rad_s: float) -> int:
    return -1 if velocity_rad_s * math.cos(angle_from_bottom_rad) > 1e-9 else 1


def direction_grid(direction, w0: float) -> tuple[np.ndarray, np.ndarray]:
    """The student's and the right answers over (rate, angle): two arrays of +1 and -1."""
    yours = np.array([[float(direction(float(a), float(r * w0))) for a in ANGLES_RAD] for r in RATES_PER_W0])
    right = np.array([[right_direction(float(a), float(r * w0)) for a in ANGLES_RAD] for r in RATES_PER_W0])
    return yours, right


def disagreement_lines(yours: np.ndarray, right: np.ndarray) -> list[str]:
    """Where the student's rule parts from -sign(alpha' cos(alpha)), below and above the horizontal; when it parts
    only where alpha' cos(alpha) = 0 (at rest, exactly horizontal), that convention instead."""
    above = np.abs(ANGLES_RAD) > math.pi / 2 + 1e-9
    below = np.abs(ANGLES_RAD) < math.pi / 2 - 1e-9
    moving = np.abs(RATES_PER_W0) > 1e-9  # at rest and exactly horizontal the lab's +1 is a convention
    wrong = yours != right
    below_share, above_share = wrong[moving][:, below].mean(), wrong[moving][:, above].mean()
    if not wrong.any():
        return ["your pumping_direction matches -sign(alpha' cos(alpha)) everywhere, above the horizontal too"]
    if below_share == 0 and above_share == 0:
        gives = sorted({float(v) for v in yours[wrong]})
        said = " or ".join(f"{v:+g}" if v else "0" for v in gives)
        return [f"your pumping_direction follows -sign(alpha' cos(alpha)) wherever the pendulum moves, but gives "
                f"{said} only where alpha' cos(alpha) = 0 (at rest, or exactly horizontal): the lab asks for +1 "
                "there, treating |alpha' cos(alpha)| below 1e-9 as 0 (math.cos(pi / 2) is 6e-17)"]
    lines = [f"your pumping_direction differs from -sign(alpha' cos(alpha)) on {_percent(below_share)} of the "
             f"map below the horizontal and {_percent(above_share)} above it"]
    if above_share > 0.9 and below_share < 0.1:
        lines.append("  right below the horizontal, flipped above it: there cos(alpha) < 0 and the direction "
                     "reverses (is cos(alpha) missing?)")
    elif below_share > 0.9 and above_share > 0.9:
        lines.append("  flipped everywhere: that brakes the swing; accelerate against alpha' cos(alpha)")
    return lines


def _percent(share: float) -> str:
    return "under 1 %" if 0 < share < 0.005 else f"{100 * share:.0f} %"


def plot_direction_map(axes, yours: np.ndarray, right: np.ndarray) -> None:
    """Two panels: the student's rule and the right one, +1 and -1 in two colours, the horizontal marked."""
    extent = (math.degrees(ANGLES_RAD[0]), math.degrees(ANGLES_RAD[-1]), RATES_PER_W0[0], RATES_PER_W0[-1])
    for axis, grid, title in ((axes[0], yours, "your pumping_direction"), (axes[1], right, "-sign(alpha' cos alpha)")):
        axis.imshow(grid, origin="lower", extent=extent, aspect="auto", cmap="coolwarm", vmin=-1, vmax=1,
                    interpolation="nearest")
        for horizontal in (-90, 90):
            axis.axvline(horizontal, color="black", linestyle=":", linewidth=1)
        axis.set(title=title, xlabel="angle from the bottom (deg)")
    axes[0].set_ylabel("rate / w0")
