"""The classical swing-up controllers: one module each in this package, each with a `CONTROLLER` that names it
and gives its host-side class (run from the laptop), its device design (a blob the rig runs itself) and the
blob's kind. The CLI, the demo, deploy, adapt, the rig queue and the docs' lists read this registry; adding a
controller is adding a module here and its test (plus a C++ runtime when its blob is of a new kind).

Names are found without importing the modules (the CLI's choices stay cheap); a module is loaded when its
controller is first asked for."""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable
from dataclasses import dataclass

from pendkit.errors import ConfigError

DEFAULT_CONTROLLER = "energy"


@dataclass(frozen=True)
class ClassicalController:
    """A classical swing-up. `host(env)`: the policy that runs it from the laptop (`policy(observation, state)`,
    with `reset`); `design(params, config=, weights=, limits=, observer_gains=)`: its blob for a rig's device;
    `in_adapt`: `pendkit adapt` designs and tries it on an identified rig."""

    name: str
    prose: str  # how a sentence names its swing-up: "the identified twin's minimum-time swing-up"
    label: str  # how a report names it: "energy swing-up + LQR"
    title: str  # a plot's title
    host: Callable
    design: Callable
    blob_kind: str = "swing-up"
    in_adapt: bool = False
    design_note: Callable = lambda blob: None  # what `pendkit export` should say of a design, if anything


def _module_names() -> list[str]:
    return [m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_")]


CONTROLLER_NAMES: tuple[str, ...] = tuple(sorted((m.replace("_", "-") for m in _module_names()),
                                                 key=lambda name: (name != DEFAULT_CONTROLLER, name)))


def controller_named(name: str) -> ClassicalController:
    """The controller `name` (one of `CONTROLLER_NAMES`); ConfigError naming the known ones otherwise."""
    if not isinstance(name, str) or name not in CONTROLLER_NAMES:
        raise ConfigError(f"controller must be one of {', '.join(CONTROLLER_NAMES)}, got {str(name)[:40]!r}")
    controller = importlib.import_module(f"{__name__}.{name.replace('-', '_')}").CONTROLLER
    if controller.name != name:
        raise ConfigError(f"{__name__}.{name.replace('-', '_')} registers {controller.name!r}, not {name!r}")
    return controller


def adapt_controllers() -> tuple[ClassicalController, ...]:
    """The controllers `pendkit adapt` designs for an identified rig, in the registry's order."""
    return tuple(c for c in map(controller_named, CONTROLLER_NAMES) if c.in_adapt)
