"""The report's figure: what the rig's encoder recorded beside what the prior and the identified twins
do with the same actions."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pendkit.adapt.excitation import Recording
from pendkit.adapt.identify import PRIOR_LATENCY_MS, Identification, simulate
from pendkit.adapt.replay import replay
from pendkit.encoder import wrapped_rad
from pendkit.episode import PALETTE
from pendkit.rig import RigParams
from pendkit.safe_write import replacing

SHOWN = 3


def matched_traces(recording: Recording, identification: Identification):
    """(times s, the rig's angles, the prior twin's, the identified twin's), as identification matched them:
    on the device's clock (replayed) or step by step."""
    if identification.pwm_phase_ms is not None:
        trace, phase = recording.device, identification.pwm_phase_ms
        start = recording.start_servo_target_rad
        return ((np.asarray(trace.ms) - trace.ms[0]) / 1000, np.asarray(trace.pendulum_rad),
                replay(RigParams(), phase, trace, start), replay(identification.params, phase, trace, start))
    t = np.arange(1, len(recording.actions) + 1) * RigParams().control_step_ms / 1000
    return (t, np.asarray(recording.pendulum_rad), simulate(RigParams(), PRIOR_LATENCY_MS, recording),
            simulate(identification.params, identification.latency_ms, recording))


def plot_identification(recordings: list[Recording], identification: Identification, path: str | Path,
                        cost_name: str = "matching cost") -> Path:
    """The first `SHOWN` recordings beside the prior and the identified twins, saved at `path`; the title gives
    the search's cost of each (`cost_name`: whose cost the search ranked by, e.g. a student's)."""
    from matplotlib.figure import Figure

    shown = recordings[:SHOWN]
    figure = Figure(figsize=(9, 2.2 * len(shown)), layout="constrained")
    axes = np.atleast_1d(figure.subplots(len(shown), 1))
    for number, (axis, recording) in enumerate(zip(axes, shown), start=1):
        t, rig, prior, found = matched_traces(recording, identification)
        axis.set_title(f"episode {number} of {len(recordings)}", loc="left", fontsize=9)
        degrees = lambda angles: np.degrees(wrapped_rad(angles))  # noqa: E731
        axis.plot(t, degrees(rig), color="black", lw=2, label="rig (encoder)")
        axis.plot(t, degrees(prior), color=PALETTE["limit"], lw=1, linestyle="--", label="prior twin")
        axis.plot(t, degrees(found), color=PALETTE["pendulum"], lw=1.2, label="identified twin")
        axis.set_ylabel("pendulum (deg)")
    axes[0].legend(loc="upper right")
    axes[-1].set_xlabel("time (s)" if identification.pwm_phase_ms is None else "time (s, the device's clock)")
    figure.suptitle(f"Excitation episodes: {cost_name} {identification.prior_cost:.3f} (prior) -> "
                    f"{identification.cost:.3f} (identified)")
    path = Path(path)
    alt = (f"Pendulum angle of the first {len(shown)} of {len(recordings)} excitation episodes on the rig, with "
           "the prior and the identified twins given the same actions; the identified twin follows the rig more "
           "closely.")
    with replacing(path, binary=True) as handle:  # never through a link planted there
        figure.savefig(handle, format="png", dpi=90, metadata={"Description": alt})
    return path
