"""Lab 09's runs on a rig in words: what a watchdog stop means when the hold command that follows it finds no
reading either, excitation episodes recorded behind a guard (a link that stalls on a busy laptop costs an
episode's retry, not the cell), and the chart of the gap (every run a row, one that never came up marked so)."""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable

from pendkit.link.driver import RigLinkError
from pendkit.rig import RigParams

_HOLD_FAILED = re.compile(r" \(the hold command failed too: (\w+)\)$")


def stop_said(reason: str, observation_timeout_s: float) -> str:
    """A guarded run's stop reason for a student. `run_guarded` sends the hold command as one more step, and that
    step waits for a reading as every step does: when none comes within the link's timeout it raises, and the
    reason ends "(the hold command failed too: RigLinkError)". Said here as what happened and what holds the rig."""
    found = _HOLD_FAILED.search(reason)
    if found is None:
        return reason
    hold_ms = RigParams().watchdog_timeout_ms
    return (f"{reason[:found.start()]}; after the hold command no reading came back within the link's "
            f"{observation_timeout_s:g} s either ({found.group(1)}), so the laptop cannot see the rig hold, but the "
            f"rig's own watchdog holds the servo {hold_ms:.0f} ms after the last command it received. A busy laptop "
            "stalls the virtual rig's link: run the cell again")


def record_on_the_rig(env, excitations: Iterable, record: Callable, attempts: int = 2,
                      report: Callable[[str], None] = print) -> list:
    """`record(env, excitation, seed=k)` for each excitation episode; an episode whose link stalls (a
    `RigLinkError`: no reading within the link's timeout) is recorded again, up to `attempts` times, then left out
    with a line saying so. Raises `RigLinkError` with what to do when no episode could be recorded."""
    recordings, lost = [], 0
    for k, excitation in enumerate(excitations):
        for attempt in range(1, attempts + 1):
            try:
                recordings.append(record(env, excitation, seed=k))
                break
            except RigLinkError as error:
                again = attempt < attempts
                report(f"excitation episode {k + 1}: the link stalled ({error}); "
                       + ("recording it again (the rig resets itself first)" if again
                          else f"left out after {attempts} tries: the search uses the other episodes"))
                lost += not again
    if not recordings:
        raise RigLinkError(f"no excitation episode could be recorded: the link stalled in all {lost} (a busy "
                           "laptop stalls the virtual rig; close other work), then run this cell again")
    return recordings


def gap_chart(results: list[dict]):
    """The summary chart of lab 09: time to upright, balance error and return per run (`measured`'s dicts), twins blue,
    rigs orange. A run not upright for its last 2 s (never up, up and fallen, or up too late to hold) has no bar, so
    it gets a "not up for the last 2 s" mark at 0 ("stopped" when the watchdog ended it: `measured`'s "stopped");
    the y-limits cover every row (matplotlib's own limits stop at the last finite bar, which drops a last row that
    never came up)."""
    import matplotlib.pyplot as plt

    names = [r["name"] for r in results]
    rows = range(len(names))
    figure, axes = plt.subplots(1, 3, figsize=(13, 3.5), layout="constrained")
    for axis, key, label in ((axes[0], "upright_s", "time to upright (s)"),
                             (axes[1], "error_deg", "balance error (deg)"),
                             (axes[2], "return", "return (the whole run; higher is better)")):
        values = [float("nan") if r[key] is None or (key == "return" and r.get("stopped")) else r[key]
                  for r in results]
        colours = ["#0072B2" if "twin" in n else "#E69F00" for n in names]
        axis.barh(rows, values, color=colours)
        for row, value, colour, result in zip(rows, values, colours, results):
            if value != value:  # NaN: not upright for the run's last 2 s (a return: stopped, so not comparable)
                axis.plot([0.0], [row], marker="x", color=colour, markersize=8, clip_on=False)
                axis.annotate("stopped" if result.get("stopped") else "not up for the last 2 s", (0.0, row),
                              xytext=(8, 0), textcoords="offset points", va="center", color=colour)
        axis.set_ylim(-0.5, len(names) - 0.5)
        axis.invert_yaxis()  # the first run at the top, as the table printed them
        if key == "return":  # returns are negative: bars to the left of 0
            axis.set_xlim(right=0.0)
        else:
            axis.set_xlim(left=0.0)
        axis.set_xlabel(label)
    axes[0].set_yticks(list(rows), names)
    axes[1].set_yticks([])
    axes[2].set_yticks([])
    figure.suptitle("the sim-to-real gap, measured with your functions (blue: twin, orange: rig; x: not upright "
                    "for the run's last 2 s, or stopped by the watchdog)")
    return figure
