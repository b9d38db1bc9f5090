"""Observation features and the reward, as functions of a `RigState` (no MuJoCo, no broker)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from operator import attrgetter

import numpy as np

from pendkit.backend_contract import RigState
from pendkit.errors import ConfigError

TWO_PI = 2 * math.pi
# Reward weight of the squared pendulum rate in (rev/s)^2 (paper, "Reward Calculation").
VELOCITY_PENALTY_WEIGHT = 0.5


# "Upright" everywhere in the kit (benchmarks' solved rule, CLI evaluation, widgets, labs): within this of the top.
UPRIGHT_RAD = 0.3
# The solved rule's tail: an episode is solved when its last this many control steps stay upright.
SOLVED_TAIL_STEPS = 200


def holds_upright(angles_from_upright_rad, tail_steps: int) -> bool:
    """Whether the last `tail_steps` angles all lie within UPRIGHT_RAD of the top (the solved rule)."""
    angles = np.abs(np.asarray(angles_from_upright_rad, dtype=float))
    return len(angles) >= tail_steps and bool(angles[-tail_steps:].max() < UPRIGHT_RAD)


def time_to_upright_s(angles_from_upright_rad, dt_s: float) -> float | None:
    """Start of the final run of |theta| < UPRIGHT_RAD that lasts to the end; None if the end is not upright."""
    angles = np.abs(np.asarray(angles_from_upright_rad))
    outside = np.nonzero(angles >= UPRIGHT_RAD)[0]
    if len(outside) == 0:
        return 0.0
    if outside[-1] == len(angles) - 1:
        return None
    return float((outside[-1] + 1) * dt_s)


def pendulum_energy(angle_from_bottom_rad, velocity_rad_s, natural_frequency_rad_s: float):
    """Normalised pendulum energy 0.5 (omega / w0)^2 - cos(alpha), alpha from the bottom: -1 hanging still,
    +1 upright still. Floats or arrays."""
    return 0.5 * (np.asarray(velocity_rad_s) / natural_frequency_rad_s) ** 2 - np.cos(angle_from_bottom_rad)


def angle_from_upright_rad(state: RigState) -> float:
    """Pendulum angle from upright, wrapped to [-pi, pi)."""
    return (state.pendulum_angle_rad % TWO_PI) - math.pi


def pendulum_cos(state: RigState) -> float:
    return math.cos(angle_from_upright_rad(state))


def pendulum_sin(state: RigState) -> float:
    return math.sin(angle_from_upright_rad(state))


@dataclass(frozen=True)
class Feature:
    name: str
    unit: str
    low: float
    high: float
    read: Callable[[RigState], float]
    description: str


_INF = math.inf
FEATURES: dict[str, Feature] = {f.name: f for f in (
    Feature("pendulum_angle", "rad", -math.pi, math.pi, angle_from_upright_rad,
            "pendulum angle from upright, wrapped to [-pi, pi)"),
    Feature("pendulum_cos", "-", -1.0, 1.0, pendulum_cos,
            "cosine of the angle from upright (1 = upright)"),
    Feature("pendulum_sin", "-", -1.0, 1.0, pendulum_sin,
            "sine of the angle from upright"),
    Feature("arm_angle", "rad", -math.pi / 2, math.pi / 2, attrgetter("arm_angle_rad"),
            "arm angle (the servo command on a servo without feedback)"),
    Feature("pendulum_velocity", "rad/s", -_INF, _INF, attrgetter("pendulum_velocity_rad_s"),
            "pendulum angular velocity"),
    Feature("pendulum_acceleration", "rad/s^2", -_INF, _INF, attrgetter("pendulum_acceleration_rad_s2"),
            "pendulum angular acceleration"),
    Feature("arm_velocity", "rad/s", -_INF, _INF, attrgetter("arm_velocity_rad_s"), "arm angular velocity"),
    Feature("servo_target", "rad", -math.pi / 2, math.pi / 2, attrgetter("servo_target_rad"),
            "the servo's current target (after the action filter)"),
    Feature("time_since_action", "s", 0.0, _INF, attrgetter("time_since_action_s"),
            "time from sending the last action to this observation"),
    Feature("observation_age", "s", 0.0, _INF, attrgetter("observation_age_s"),
            "time from receiving this observation to using it"),
)}

# The paper's observation: two sensor readings, three derived rates, two timing values.
PAPER_FEATURES = ("pendulum_angle", "arm_angle", "pendulum_velocity", "pendulum_acceleration",
                  "arm_velocity", "time_since_action", "observation_age")


def resolve_features(names: tuple[str, ...] | list[str] | str) -> tuple[Feature, ...]:
    if isinstance(names, str):
        names = PAPER_FEATURES if names == "paper" else (names,)
    if not names:
        raise ConfigError(f"observation needs at least one feature; choose from {sorted(FEATURES)} "
                          "(or 'paper' for the paper's seven)")
    unknown = [n for n in names if n not in FEATURES]
    if unknown:
        raise ConfigError(f"unknown observation features {unknown}; choose from {sorted(FEATURES)}")
    if len(set(names)) != len(names):
        raise ConfigError(f"observation features repeat: {list(names)}")
    return tuple(FEATURES[n] for n in names)


def reward(state: RigState) -> float:
    """-theta^2 - 0.5 * omega^2, theta from upright in rad, omega in rev/s (0 is the best)."""
    theta = angle_from_upright_rad(state)
    omega_rev_s = state.pendulum_velocity_rad_s / TWO_PI
    return -(theta * theta) - VELOCITY_PENALTY_WEIGHT * omega_rev_s * omega_rev_s
