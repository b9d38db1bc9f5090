"""Minimum-time swing-up as an optimal-control problem on `FurutaModel`, one control step at a time.

The decision is the servo target for each 60 ms step; the servo's limits enter through its model (PD
drive clipped at the stall torque, back-EMF damping that caps the arm at the rated speed), the arm's range
through the targets' bounds, the firmware's over-spin cut-out as a bound on the pendulum's rate, and the
command path's delay as in `filtered_model`: the old target acts for the first `delay_s` of a step, the
new one after. The state carries the target in force: x = [phi, alpha, phi', alpha', target].

Two solvers, used together:

- `fastest_bang_bang`: a time-optimal input saturates, so the search tries every sequence of full-left /
  full-right targets with at most `max_switches` switches, all at once (vectorised RK4), one step deeper at
  a time, and stops at the first step where one lands in the catch set. Exact over that family, about a
  second from the hanging rest, so it also runs at every reset.
- `polish_with_ocp`: python-control's `solve_ocp` (shooting, SLSQP) on the same step map, from the search's
  inputs, with the catch set as terminal constraints; it frees the inputs to any value within the bounds.
  From a zero guess the same problem took minutes to solve or failed; from the search's guess, seconds.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field

import control
import control.optimal as opt
import numpy as np

from pendkit.checks import check_fields
from pendkit.control.model import FurutaModel
from pendkit.errors import ConfigError
from pendkit.rig import RigParams

STATE_NAMES = ("arm_angle_rad", "pendulum_angle_rad", "arm_velocity_rad_s", "pendulum_velocity_rad_s",
               "target_in_force_rad")
SUBSTEP_S = 0.01


@dataclass(frozen=True)
class SwingUpLimits:
    """Bounds of the problem. `arm_limit_rad` bounds the targets (the servo's range is pi/2; the rest is
    margin for the arm's overshoot); the catch set is where the upright LQR takes over."""

    arm_limit_rad: float = 1.4
    overspin_rad_s: float = 2 * math.pi * RigParams().overspin_limit_rev_s
    catch_angle_rad: float = 0.25
    catch_velocity_rad_s: float = 1.5
    catch_arm_velocity_rad_s: float = 6.0
    catch_arm_angle_rad: float = 0.9

    def __post_init__(self) -> None:
        check_fields(self, lambda limit: limit > 0, "> 0")
        if self.arm_limit_rad > math.pi / 2:
            raise ConfigError(f"arm_limit_rad must be within the servo's range (pi/2), got {self.arm_limit_rad}")

    def in_catch_set(self, x: np.ndarray) -> np.ndarray:
        """True where the state (5,) or states (5, n) are close enough to upright to hand over."""
        theta = np.abs((x[1] % (2 * math.pi)) - math.pi)
        return ((theta <= self.catch_angle_rad) & (np.abs(x[3]) <= self.catch_velocity_rad_s)
                & (np.abs(x[2]) <= self.catch_arm_velocity_rad_s) & (np.abs(x[0]) <= self.catch_arm_angle_rad))


class StepModel:
    """One control step of the nonlinear model, with the command's delay (RK4, fixed substeps)."""

    def __init__(self, model: FurutaModel, period_s: float, delay_s: float = 0.0) -> None:
        if not period_s > 0 or not 0 <= delay_s < period_s:
            raise ConfigError(f"need period_s > 0 and 0 <= delay_s < period_s, got {period_s}, {delay_s}")
        self.model, self.period_s, self.delay_s = model, period_s, delay_s

    @classmethod
    def for_env(cls, env) -> StepModel:
        base = env.unwrapped
        return cls(FurutaModel.from_rig(base.params), base.dt, min(base.timing.design_delay_s, 0.9 * base.dt))

    def step(self, x: np.ndarray, target_rad) -> np.ndarray:
        """The state after one step with `target_rad` sent now; x of shape (5,) or (5, n). Float32 states stay
        float32 (the search's many sequences), anything else is computed in float64."""
        x = np.asarray(x)
        dtype = np.float32 if x.dtype == np.float32 else np.float64
        x, target_rad = x.astype(dtype, copy=False), np.asarray(target_rad, dtype=dtype)
        q = self._integrate(x[:4], x[4], self.delay_s)
        q = self._integrate(q, target_rad, self.period_s - self.delay_s)
        return np.concatenate([q, np.broadcast_to(target_rad, x[4].shape)[None]])

    def _integrate(self, q: np.ndarray, target_rad, duration_s: float) -> np.ndarray:
        if duration_s <= 0:
            return q
        count = max(1, math.ceil(duration_s / SUBSTEP_S - 1e-9))
        h = duration_s / count
        for _ in range(count):
            k1 = self._rates(q, target_rad)
            k2 = self._rates(q + 0.5 * h * k1, target_rad)
            k3 = self._rates(q + 0.5 * h * k2, target_rad)
            k4 = self._rates(q + h * k3, target_rad)
            q = q + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        return q

    def _rates(self, q: np.ndarray, target_rad) -> np.ndarray:
        return np.concatenate([q[2:], self.model.accelerations(q, target_rad)])

    def simulate(self, x0: np.ndarray, targets_rad: np.ndarray) -> np.ndarray:
        """States (len(targets) + 1, 5) from x0 under the targets, one per step."""
        states = [np.asarray(x0, dtype=float)]
        for target in np.asarray(targets_rad, dtype=float).reshape(-1):
            states.append(self.step(states[-1], target))
        return np.array(states)

    def as_nlsys(self) -> control.NonlinearIOSystem:
        """The step map as a discrete-time python-control system (input: the target sent this step)."""
        return control.nlsys(lambda t, x, u, params: self.step(x, float(u[0])), None, dt=self.period_s,
                             states=list(STATE_NAMES), inputs=["servo_target_rad"], outputs=list(STATE_NAMES),
                             name="furuta_step")


@dataclass
class Plan:
    """A planned swing-up: the targets to send, one per step, and the states they lead to."""

    targets_rad: np.ndarray
    states: np.ndarray
    period_s: float
    solver: str
    solve_s: float = 0.0
    notes: dict = field(default_factory=dict)

    @property
    def duration_s(self) -> float:
        return len(self.targets_rad) * self.period_s


def initial_state(arm_rad: float = 0.0, pendulum_rad: float = 0.0, arm_velocity_rad_s: float = 0.0,
                  pendulum_velocity_rad_s: float = 0.0, target_rad: float | None = None) -> np.ndarray:
    """The optimiser's state vector; the target in force defaults to the arm's angle (at rest)."""
    return np.array([arm_rad, pendulum_rad, arm_velocity_rad_s, pendulum_velocity_rad_s,
                     arm_rad if target_rad is None else target_rad], dtype=float)


def fastest_bang_bang(step_model: StepModel, x0, limits: SwingUpLimits | None = None, max_steps: int = 40,
                      max_switches: int = 4) -> Plan | None:
    """The fewest steps of full-left/full-right targets (at most `max_switches` switches) that reach the
    catch set without over-spinning; among those, the one ending nearest upright and slowest. None if no
    such sequence within `max_steps`."""
    limits = limits or SwingUpLimits()
    started = time.perf_counter()
    x0 = np.asarray(x0, dtype=float)
    if limits.in_catch_set(x0):
        return Plan(np.zeros(0), x0[None], step_model.period_s, "bang-bang", 0.0)
    amplitude = limits.arm_limit_rad
    # float32: several times faster here (numpy's vectorised sin/cos); the plan is re-simulated in float64
    states = np.repeat(x0[:, None], 2, axis=1).astype(np.float32)
    signs = np.array([1.0, -1.0], dtype=np.float32)
    switches = np.zeros(2, dtype=int)
    parents: list[np.ndarray] = [np.array([0, 0])]
    all_signs: list[np.ndarray] = [signs]
    for depth in range(1, max_steps + 1):
        states = _step_in_chunks(step_model, states, signs * amplitude)
        alive = np.abs(states[3]) <= limits.overspin_rad_s
        caught = limits.in_catch_set(states) & alive
        if caught.any():
            index = _best_catch(states, caught)
            targets = _trace_back(index, parents, all_signs).astype(float) * amplitude
            return Plan(targets, step_model.simulate(x0, targets), step_model.period_s, "bang-bang",
                        time.perf_counter() - started, {"sequences": int(states.shape[1])})
        if depth == max_steps:
            break
        keep = np.nonzero(alive)[0]
        can_switch = keep[switches[keep] < max_switches]
        parent = np.concatenate([keep, can_switch])
        signs = np.concatenate([signs[keep], -signs[can_switch]])
        switches = np.concatenate([switches[keep], switches[can_switch] + 1])
        states = states[:, parent]
        parents.append(parent)
        all_signs.append(signs)
    return None


def _step_in_chunks(step_model: StepModel, states: np.ndarray, targets_rad: np.ndarray,
                    chunk: int = 16384) -> np.ndarray:
    """`step_model.step` over many sequences, a cache-sized chunk at a time (about twice as fast as one go)."""
    if states.shape[1] <= chunk:  # also none left: every sequence over-spun
        return step_model.step(states, targets_rad)
    return np.concatenate([step_model.step(states[:, i:i + chunk], targets_rad[i:i + chunk])
                           for i in range(0, states.shape[1], chunk)], axis=1)


def _best_catch(states: np.ndarray, caught: np.ndarray) -> int:
    theta = (states[1] % (2 * math.pi)) - math.pi
    cost = theta**2 + 0.05 * states[3] ** 2 + 0.005 * states[2] ** 2
    return int(np.argmin(np.where(caught, cost, np.inf)))


def _trace_back(index: int, parents: list[np.ndarray], all_signs: list[np.ndarray]) -> np.ndarray:
    """The sign sequence that ends at `index` of the last depth."""
    sequence = []
    for depth in range(len(all_signs) - 1, -1, -1):
        sequence.append(all_signs[depth][index])
        if depth > 0:
            index = parents[depth][index]
    return np.array(sequence[::-1])




def catch_set_constraint(system: control.NonlinearIOSystem, limits: SwingUpLimits, upright_rad: float = math.pi):
    """The catch set around `upright_rad` (pi or -pi, as the plan arrives) as a python-control terminal
    constraint on the state."""
    lower = [-limits.catch_arm_angle_rad, upright_rad - limits.catch_angle_rad, -limits.catch_arm_velocity_rad_s,
             -limits.catch_velocity_rad_s, -np.inf]
    upper = [limits.catch_arm_angle_rad, upright_rad + limits.catch_angle_rad, limits.catch_arm_velocity_rad_s,
             limits.catch_velocity_rad_s, np.inf]
    return opt.state_range_constraint(system, lower, upper)


def upright_cost(system: control.NonlinearIOSystem, upright_rad: float = math.pi):
    """Terminal cost: squared distance from standing still upright (rates weighted lower)."""
    weights = np.diag([0.1, 10.0, 0.1, 1.0, 0.0])
    goal = np.array([0.0, upright_rad, 0.0, 0.0, 0.0])
    return opt.quadratic_cost(system, weights, None, x0=goal)


def solve_swing_up(step_model: StepModel, x0, steps: int, cost, constraints, terminal_constraints,
                   initial_guess=None, max_iterations: int = 100, terminal_cost=None) -> Plan | None:
    """Solve a swing-up problem posed by the caller (the running cost, trajectory and terminal constraints,
    a terminal cost, all in python-control's form) over `steps` control steps with
    `control.optimal.solve_ocp` (shooting, SLSQP). None if it finds no solution."""
    if steps < 1:
        raise ConfigError(f"steps must be >= 1, got {steps}")
    system = step_model.as_nlsys()
    timepts = np.arange(steps + 1) * step_model.period_s
    guess = None if initial_guess is None else np.append(np.asarray(initial_guess, dtype=float), 0.0)[None, :]
    started = time.perf_counter()
    with warnings.catch_warnings():  # unbounded rows of a range constraint; a failed solve is reported as None
        warnings.simplefilter("ignore")
        result = opt.solve_ocp(system, timepts, np.asarray(x0, dtype=float), cost, constraints,
                               terminal_cost=terminal_cost, terminal_constraints=terminal_constraints,
                               initial_guess=guess, minimize_method="SLSQP",
                               minimize_options={"maxiter": max_iterations}, print_summary=False)
    elapsed = time.perf_counter() - started
    if not result.success:
        return None
    targets = np.asarray(result.inputs).reshape(-1)[:steps]
    return Plan(targets, step_model.simulate(x0, targets), step_model.period_s, "solve_ocp", elapsed,
                {"iterations": int(getattr(result, "nit", 0) or 0), "cost": float(result.cost)})


def approach_problem(step_model: StepModel, limits: SwingUpLimits, upright_rad: float):
    """The kit's final-approach problem in python-control's form: (running cost, trajectory constraints,
    terminal constraints, terminal cost). Lab 05 asks students for the same pieces."""
    system = step_model.as_nlsys()
    bounds = [opt.input_range_constraint(system, [-limits.arm_limit_rad], [limits.arm_limit_rad]),
              opt.state_range_constraint(system, [-np.inf, -np.inf, -np.inf, -limits.overspin_rad_s, -np.inf],
                                         [np.inf, np.inf, np.inf, limits.overspin_rad_s, np.inf])]
    effort = opt.quadratic_cost(system, None, np.array([[1e-3]]))
    return effort, bounds, [catch_set_constraint(system, limits, upright_rad)], upright_cost(system, upright_rad)


def polish_approach(step_model: StepModel, plan: Plan, steps: int = 10, problem=None,
                    limits: SwingUpLimits | None = None, max_iterations: int = 60) -> Plan:
    """`plan` with its last `steps` targets re-solved by `solve_ocp` (free, bounded targets; the catch set as
    terminal constraint; the terminal cost brings the arrival nearer to standing still upright). A short
    horizon keeps SLSQP quick and reliable (about 3 s for 10 steps); where it fails, `plan` as it was.
    `problem` = (running cost, constraints, terminal constraints, terminal cost), default `approach_problem`."""
    limits = limits or SwingUpLimits()
    count = len(plan.targets_rad)
    steps = min(steps, count)
    if steps == 0:
        return plan
    start = count - steps
    upright = math.pi * round(plan.states[-1][1] / math.pi)
    cost, constraints, terminal, terminal_cost = problem or approach_problem(step_model, limits, upright)
    tail = solve_swing_up(step_model, plan.states[start], steps, cost, constraints, terminal,
                          plan.targets_rad[start:], max_iterations, terminal_cost=terminal_cost)
    if tail is None:
        return plan
    targets = np.concatenate([plan.targets_rad[:start], tail.targets_rad])
    notes = {**plan.notes, "polished_steps": steps, "polish_s": tail.solve_s, "polish_cost": tail.notes["cost"]}
    return Plan(targets, step_model.simulate(plan.states[0], targets), plan.period_s, f"{plan.solver}+solve_ocp",
                plan.solve_s + tail.solve_s, notes)


def polish_with_ocp(step_model: StepModel, plan: Plan, limits: SwingUpLimits | None = None,
                    steps: int | None = None, max_iterations: int = 100) -> Plan | None:
    """`plan` re-solved by `solve_ocp` with free (bounded) targets over `steps` (default: as many as the plan),
    from the plan's own targets; `steps` below the plan's asks whether any input, not only full ones, is
    faster. None where the solver finds no solution."""
    limits = limits or SwingUpLimits()
    steps = len(plan.targets_rad) if steps is None else steps
    upright = math.pi * round(plan.states[-1][1] / math.pi)
    effort, bounds, terminal, terminal_cost = approach_problem(step_model, limits, upright)
    guess = np.resize(plan.targets_rad, steps) if steps != len(plan.targets_rad) else plan.targets_rad
    return solve_swing_up(step_model, plan.states[0], steps, effort, bounds, terminal, guess, max_iterations,
                          terminal_cost=terminal_cost)
