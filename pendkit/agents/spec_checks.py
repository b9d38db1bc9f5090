"""What a learning run may be built from, checked before anything is built: every field of a `RunSpec` and every
agent setting of its type and inside a named bound. A run folder is input like any other (a student's, a
download): `spec.max_steps = 10**9` would make `pendkit eval` run for days and `hidden: [200000, 200000]` make
`export` ask for 160 GB, so each is one `ConfigError` naming the field, its value and the allowed range.

The bounds are generous (ten times what the kit's own runs use, or more) and only keep a run to what a
laptop and a classroom rig can do.
"""

from __future__ import annotations

import dataclasses
import numbers

from pendkit.checks import is_finite_number
from pendkit.errors import ConfigError
from pendkit.rig import SERVO_PRESETS
from pendkit.sim.fidelity import FIDELITY_PRESETS, Fidelity
from pendkit.sim.randomize import parse_randomize

MAX_SEED = 2**32 - 1  # numpy's and torch's seeds
# RunSpec's whole-number fields: (lowest, highest, what they count)
SPEC_BOUNDS = {
    "seed": (0, MAX_SEED, "numpy's and torch's seeds"),
    "max_steps": (1, 5_000, "steps per episode: 5 minutes at 60 ms"),
    "delay_steps": (0, 50, "control steps of observation delay: 3 s at 60 ms"),
}
# Agent settings that size what is allocated or how long a step takes
AGENT_BOUNDS = {
    "hidden": (1, 1024, "units per layer"),
    "gru_size": (1, 512, "GRU units"),
    "buffer_capacity": (1, 10_000_000, "stored steps"),
    "batch_size": (1, 65_536, "samples per update"),
    "sequence_length": (1, 1_000, "steps per replayed stretch"),
    "burn_in": (0, 1_000, "steps before a stretch"),
    "learning_starts": (0, 10**12, "steps before updates: 10**9 is a run that never learns"),
    "update_every": (1, 100_000, "steps per update"),
    "target_update_every": (1, 10_000_000, "updates"),
    "epsilon_decay_steps": (1, 100_000_000, "steps"),
    "policy_delay": (1, 1_000, "critic updates"),
}
MAX_LAYERS = 8


def is_whole(value) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def check_whole(name: str, value, bounds: tuple[int, int, str]) -> None:
    low, high, what = bounds
    if not is_whole(value) or not low <= value <= high:
        raise ConfigError(f"{name} = {value!r} is not a whole number in {low}..{high} ({what})")


def check_hidden(value) -> None:
    low, high, what = AGENT_BOUNDS["hidden"]
    if (not isinstance(value, (list, tuple)) or not 1 <= len(value) <= MAX_LAYERS
            or not all(is_whole(width) and low <= width <= high for width in value)):
        shown = repr(value) if len(repr(value)) < 80 else repr(value)[:77] + "..."
        raise ConfigError(f"agent: hidden = {shown} is not a list of 1..{MAX_LAYERS} layer widths in {low}..{high} "
                          f"({what})")


def check_agent_values(settings) -> None:
    """What can be checked without the agent's own config (no torch needed): a mapping of names to plain
    values, and the sizes in AGENT_BOUNDS."""
    if not isinstance(settings, dict) or not all(isinstance(key, str) for key in settings):
        raise ConfigError(f"agent: {repr(settings)[:60]} is not a mapping of setting names to values")
    for name, value in settings.items():
        if name == "hidden":
            check_hidden(value)
        elif name in AGENT_BOUNDS:
            check_whole(f"agent: {name}", value, AGENT_BOUNDS[name])
        elif not (isinstance(value, (bool, str)) or is_finite_number(value)):
            raise ConfigError(f"agent: {name} = {repr(value)[:60]} is not a finite number, true/false or text")


def check_agent_types(config_class, settings: dict) -> None:
    """Each setting of the type its field in `config_class` has (its default's): a whole number where the
    default is one, a finite number where it is a float, true/false where it is a flag."""
    defaults = {f.name: f.default for f in dataclasses.fields(config_class)}
    for name, value in settings.items():
        default = defaults.get(name)
        if isinstance(default, bool):
            wrong = not isinstance(value, bool)
        elif isinstance(default, int):
            wrong = not is_whole(value)
        elif isinstance(default, float):
            wrong = not is_finite_number(value)
        else:
            continue
        if wrong:
            kind = {bool: "true or false", int: "a whole number"}.get(type(default), "a finite number")
            raise ConfigError(f"agent: {name} = {value!r} is not {kind} (as its default {default!r})")


def check_run_spec(spec) -> None:
    """Every field of `spec` (a RunSpec) of its type and in range; ConfigError naming the first that is not (the
    learner's name is RunSpec's to resolve)."""

    if not isinstance(spec.learner, str):
        raise ConfigError(f"learner = {spec.learner!r} is not a learner's name")
    named = isinstance(spec.fidelity, str) and spec.fidelity in FIDELITY_PRESETS
    if not (named or isinstance(spec.fidelity, Fidelity)):
        raise ConfigError(f"fidelity = {spec.fidelity!r} is not one of {', '.join(FIDELITY_PRESETS)}")
    for name, bounds in SPEC_BOUNDS.items():
        check_whole(name, getattr(spec, name), bounds)
    if spec.preset is not None and not (isinstance(spec.preset, str) and spec.preset in SERVO_PRESETS):
        raise ConfigError(f"preset = {spec.preset!r} is not one of {', '.join(SERVO_PRESETS)} (or none)")
    if not isinstance(spec.randomize, str):
        raise ConfigError(f"randomize = {spec.randomize!r} is not text (e.g. 'servo,latency' or 'robust')")
    parse_randomize(spec.randomize)
    check_agent_values(spec.agent)
