"""Lab 05: what the student's approach problem did to the search's plan, in words."""

from __future__ import annotations

import math

import numpy as np


def _from_upright_deg(state) -> float:
    return math.degrees(abs(state[1] - math.pi * round(state[1] / math.pi)))


def approach_lines(search, approach, terminal_cost) -> list[str]:
    """Lines comparing the solved approach's arrival with the search's alone, and the student's terminal cost
    at both and standing still upright (where it must be 0)."""
    before, after = np.asarray(search.states[-1], float), np.asarray(approach.states[-1], float)
    upright = math.pi * round(before[1] / math.pi)
    lines = [f"your approach: solved in {approach.solve_s:.1f} s"]
    if np.allclose(before[:4], after[:4], atol=1e-6):
        typical = float(np.median(np.abs(approach.targets_rad)))
        lines.append(f"  it kept the search's motion, lowering its targets (mostly +-{typical:.2f} rad instead of "
                     f"+-{float(np.median(np.abs(search.targets_rad))):.2f}): the servo runs at full speed all "
                     "through the approach either way")
        lines.append(f"  both arrive {_from_upright_deg(after):.1f} deg from upright at {after[3]:+.2f} rad/s")
    else:
        lines.append(f"  the plan arrives {_from_upright_deg(after):.1f} deg from upright at {after[3]:+.2f} rad/s "
                     f"(the search alone: {_from_upright_deg(before):.1f} deg, {before[3]:+.2f} rad/s)")
    at_upright = float(terminal_cost([0.0, upright, 0.0, 0.0, 0.0], upright))
    lines.append(f"  your terminal cost: {float(terminal_cost(list(after), upright)):.3f} at the plan's arrival, "
                 f"{float(terminal_cost(list(before), upright)):.3f} at the search's, {at_upright:.3g} standing still "
                 "upright")
    if abs(at_upright) > 1e-9:
        from pendkit.grading.suites.lab05 import cost_note

        still = [0.0, upright, 0.0, 0.0, 0.0]
        cause = cost_note(at_upright, still, upright) or ": check each term against c(x)"
        lines.append("  standing still upright must cost 0 (solve_ocp steers towards your cost's lowest point)" + cause)
    return lines
