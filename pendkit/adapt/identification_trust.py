"""An identification `pendkit adapt` does not deploy from (issue 72, part 5).

Recordings that pass every check (`pendkit.adapt.recording_checks`) can still defeat identification: an encoder
wired to count the other way, an arm slipping on its horn, a pendulum loose on its shaft. The search then ends
somewhere, and its matching cost says how far from the recordings. A twin worth deploying from follows the
swings: its cost is a small share of what a pendulum that never moved from where it hung would cost on the same
recordings (the fits in docs/results/transfer.md reach 0.1-10% of it). At more than half of it (an RMS angle
error over 70% of the pendulum's own RMS swing) the twin explains little of what the rig did, and what is
designed or trained on it is designed for another rig.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from pendkit.adapt.excitation import Recording
from pendkit.adapt.identify import Identification, on_device_clock
from pendkit.adapt.replay import angle_error_rad2

UNTRUSTED_COST_SHARE = 0.5  # of a motionless pendulum's matching cost, on the same recordings
WHAT_TO_CHECK = ("is the encoder counting the way the build guide sets it (its CW/CCW pin), and are the arm and the "
                 "pendulum tight on their shafts?")


def motionless_cost(recordings: Sequence[Recording], device_clock: bool) -> float:
    """The matching cost of a twin whose pendulum never moves from where it hung, as identification measures
    it: on the device's trace (`device_clock`) or on the host's steps, averaged over the recordings."""
    if device_clock:
        return float(np.mean([angle_error_rad2(r.device.pendulum_rad[0], r.device.pendulum_rad)
                              for r in recordings]))
    return float(np.mean([angle_error_rad2(r.start_pendulum_rad, r.pendulum_rad) for r in recordings]))


def distrust(identification: Identification, recordings: Sequence[Recording]) -> str | None:
    """Why `identification` is not to be deployed from (one line), or None when it is. `recordings`: the ones
    its matching cost was measured on."""
    if not (math.isfinite(identification.cost) and math.isfinite(identification.prior_cost)):
        return (f"the identification's matching cost is {identification.prior_cost:.3g} (prior) -> "
                f"{identification.cost:.3g}, not a number it can be judged by: record again")
    device_clock = identification.pwm_phase_ms is not None and on_device_clock(list(recordings))
    still = motionless_cost(recordings, device_clock)
    if identification.cost > UNTRUSTED_COST_SHARE * still:
        return (f"the identified twin matches the recordings hardly better than a pendulum that never moved "
                f"(matching cost {identification.cost:.4f} rad^2 against {still:.4f}): {WHAT_TO_CHECK}")
    return None


def untrusted_markdown(report: dict) -> str:
    """The report of an identification not deployed from: why, what was identified, what to do."""
    rows = "\n".join(f"| {name} | {report['prior'].get(name, float('nan')):.4g} | {value:.4g} |"
                     for name, value in report["identified"].items())
    return (f"# Adaptation of {report['rig']}: not deployed\n\n"
            f"The identification is not trusted: {report['untrusted']}.\n\n"
            "Nothing deployable was written (no rig.json, policy or controller blobs); the recordings are kept "
            "(`excitation.json`, `excitation-logs/`), and the figure below shows the recorded swings beside the "
            "twins'. `pendkit adapt --deploy-untrusted` deploys from such an identification all the same.\n\n"
            f"| parameter | prior | identified |\n|---|---|---|\n{rows}\n\n"
            f"Matching cost (mean squared angle error, rad^2): prior {report['matching_cost']['prior']:.4f}, "
            f"identified {report['matching_cost']['identified']:.4f}.\n\n"
            "![recorded and simulated swings](identification.png)\n")
