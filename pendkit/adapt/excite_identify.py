"""(a) and (b) of `pendkit adapt`: as few excitation episodes as the identification needs, then the twin.

The rig's time is the class's scarcest: the excitation starts with `min_excitation_episodes` and records one
more (up to `excitation_episodes`) only while the recordings leave the servo's speed uncertain (the interval
over which the twin still matches them, `pendkit.adapt.uncertainty.fit_spread`, wider than
`EXCITATION_SPREAD`) and the last episode still narrowed it, each time identifying again from every recording
so far (one search, started beside the fit before it, on half the evaluations).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

from pendkit.adapt.excitation import ADAPT_FREE_STEPS, Recording, schedule
from pendkit.adapt.identify import Identification, identify_best, refine_servo
from pendkit.adapt.progress import work_bar
from pendkit.adapt.recording_checks import record_checked
from pendkit.adapt.uncertainty import Interval, fit_spread
from pendkit.rig import RigParams

# the fields the excitation must pin before it stops, and how far (x/÷) their interval may reach from the fit:
# the device's plans follow the servo's speed. Not the loop's damping: on the hidden-rig stand-ins three episodes
# left it anywhere within the walk's reach (x/÷2.7) and a fourth seldom narrowed it, while every episode added
# after a fit costs the rig that fit's wall time too (the rig waits, held, between episodes)
PINNED = ("servo_speed_s_per_60deg",)
EXCITATION_SPREAD = 1.12
NARROWING = 0.2  # an episode that took less than this share off the widest interval's excess was not worth it


@dataclass
class Identified:
    """What (a) and (b) leave: every recording (jumps first, then loop episodes), the prior, the logs by file
    name, the identification and, when asked for, what the recordings allow about it."""

    recordings: list[Recording]
    jumps: list[Recording]
    prior: RigParams
    logs: dict[str, bytes]
    identification: Identification
    spread: dict[str, Interval] | None
    widest: dict[str, float]  # each pinned field's interval, its farther end as a ratio to the fit
    unrefined: Identification | None = None  # the fit before the loop episodes refined its servo (None: none)


def widest_ratio(identification: Identification, spread: dict[str, Interval]) -> dict[str, float]:
    """Each pinned field's interval as its farther end's ratio to the fit (1.1: within 10% either way)."""
    values = identification.values()
    return {name: max(values[name] / spread[name][0], spread[name][1] / values[name]) for name in PINNED}


def excite_and_identify(rig, config, deadline: float, say: Callable[[str], None],
                        tolerance: float | None) -> Identified:
    """Record, identify, and record more while the fit is uncertain; the identification's searches end by
    `deadline` (a `time.time()`). `tolerance`: the matching cost's tolerance of the spread (None: the spread
    is still measured, at 1.0, to decide the excitation's length, and not returned)."""
    plan = schedule(config.excitation_episodes, free_steps=ADAPT_FREE_STEPS)
    first = min(config.min_excitation_episodes, config.excitation_episodes)
    with work_bar("(a) excitation", first, "episode") as bar:
        jumps, prior, logs = record_checked(rig, plan[:first], config.seed, on_episode=bar.advance)
    identification, excess = None, math.inf
    while True:
        identification = _identify(jumps, prior, config, deadline, identification)
        spread = fit_spread(identification, jumps, tolerance or 1.0)
        widest = widest_ratio(identification, spread)
        excess, narrowed = max(widest.values()) - 1, excess - (max(widest.values()) - 1)
        if len(jumps) >= len(plan) or excess <= EXCITATION_SPREAD - 1:
            break
        if narrowed < NARROWING * (excess + narrowed) or time.time() > deadline:
            say(f"(a) the recordings leave {_described(widest)}, and "
                + ("the last episode hardly narrowed it: no more" if time.time() <= deadline
                   else "identification's time is up: no more"))
            break
        say(f"(a) the recordings leave {_described(widest)}: one more excitation episode")
        more, _, more_logs = record_checked(rig, plan[len(jumps):len(jumps) + 1], config.seed + len(jumps))
        jumps = jumps + more
        logs.update({f"{len(jumps):02d}-{name}": contents for name, contents in more_logs.items()})
    recordings, unrefined = jumps, None
    if config.loop_episodes:  # the loop's small steps: the servo refined about that fit over all of them
        loops, _, loop_logs = record_checked(rig, schedule(0, config.loop_episodes), config.seed + len(jumps))
        recordings = jumps + loops
        logs.update({f"loop-{name}": contents for name, contents in loop_logs.items()})
        unrefined = identification
        identification = refine_servo(identification, recordings, prior, config.refinement_evaluations)
    return Identified(recordings, jumps, prior, logs, identification, spread if tolerance else None, widest,
                      unrefined)


def _identify(jumps: list[Recording], prior: RigParams, config, deadline: float,
              warm: Identification | None) -> Identification:
    """The first fit: `identification_restarts` searches (as the deadline allows); a later one, of more
    recordings: one search beside the fit before it, on half the evaluations."""
    searches = config.identification_restarts if warm is None else 1
    evaluations = config.identification_evaluations if warm is None else config.identification_evaluations // 2
    with work_bar("(b) identification", searches * evaluations, "twin") as bar:
        def progress(count: int, best: float) -> None:
            bar.advance(1, f"closest {best:.2g} rad^2" if math.isfinite(best) else None)

        found = identify_best(jumps, prior, evaluations, seeds=[config.seed + k for k in range(searches)],
                              progress=progress, deadline=deadline, warm=warm)
    if warm is None:
        return found
    return dataclasses.replace(found, seconds=found.seconds + warm.seconds, evaluations=found.evaluations
                               + warm.evaluations, searches=warm.searches)


def _described(widest: dict[str, float]) -> str:
    return ", ".join(f"{name} within x/÷{ratio:.2f}" for name, ratio in widest.items())


def identification_deadline(started: float, budget_s: float | None, share: float) -> float:
    """When the identification's searches must end: `share` of the budget from `started` (unbounded without one)."""
    return math.inf if budget_s is None else started + share * budget_s

