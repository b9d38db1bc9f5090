"""The rig's twin from its readings, in two stages, each from the encoder alone (a rig's parameters are
never looked at):

1. The pendulum, from the free swings that end every excitation episode: natural frequency and damping
   ratio (`pendkit.control.sysid.identify_free_swing`), each corrected by the same estimate made on the
   prior twin's own simulated swings (the arm is held by a servo, not a wall). The dowel's length is then
   the one that gives that frequency (its mass follows its length), the bearing's damping the one that
   gives that ratio.
2. Everything together by trajectory matching: the servo's speed, stall torque, loop stiffness
   (full-torque error) and loop damping (damping ratio: an underdamped servo overshoots its target, which
   the catch and the balance feel), the one-way latency, and the pendulum's length and damping refined
   about stage 1's (a servo holds the arm with a finite stiffness, which shifts the free swing's
   frequency), chosen so that the realistic twin, given the same actions from the same start, moves its
   pendulum as the rig's encoder recorded. The cost is the mean squared angle error over every recorded
   step (`matching_cost`; lab 09's students write their own); scipy's differential evolution searches
   `SERVO_BOUNDS` from the prior.

Recordings that carry the device's own readings (an env made with `log_dir`: `pendkit.adapt.replay`) are
matched on the device's clock instead, where the network cannot blur them: the search's last coordinate is
then the servo's PWM phase, not a latency, and the latency is measured from the host's clock.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from pendkit.adapt.cost_pool import CostPool, guarded_cost
from pendkit.adapt.excitation import EXCITATION_STREAM, Excitation, Recording, free_from
from pendkit.adapt.replay import angle_error_rad2, replay_cost
from pendkit.backend_contract import ServoCommand
from pendkit.control.sysid import identify_free_swing
from pendkit.errors import ConfigError
from pendkit.network import LatencyModel, NetworkImpairment
from pendkit.rig import RigParams
from pendkit.sim.fidelity import FIDELITY_PRESETS
from pendkit.timing import one_way_latency_ms, pwm_wait_ms

# name: (low, high) as a multiple of the prior's value, searched in log space; latency in ms
# (the pendulum's two are multiples of stage 1's estimate, which they refine)
SERVO_BOUNDS: dict[str, tuple[float, float]] = {
    "servo_speed_s_per_60deg": (0.4, 2.5),
    "servo_stall_torque_kg_cm": (0.25, 4.0),
    "servo_full_torque_error_deg": (0.2, 5.0),
    "servo_damping_ratio": (0.15, 1.4),
    "dowel_length_m": (0.75, 1.33),
    "pendulum_damping_n_m_s_per_rad": (0.3, 3.0),
    "latency_ms": (0.0, 40.0),
}
FITTED = tuple(SERVO_BOUNDS)
PRIOR_LATENCY_MS = 10.0
Cost = Callable[[RigParams, float, list["Recording"]], float]
# 1200 evaluations leave differential evolution short of the minimum on a clean link (3600 reach a cost 20-100x
# lower there), but on a rig's WiFi the minimum itself moves with the network's jitter and losses: 3600 doubled
# the wall time and solved no more rigs (docs/results/transfer.md), so the search stays at 1200.


@dataclass(frozen=True)
class Identification:
    """The identified rig, its latency, the cost reached (and the prior's), and what it took."""

    params: RigParams
    latency_ms: float
    cost: float
    prior_cost: float
    evaluations: int
    seconds: float
    pwm_phase_ms: float | None = None  # matched on the device's clock (None: on the host's steps)
    # the rig's network as the recordings showed it (pendkit.adapt.network_fit); None: a fixed latency, no loss
    network: NetworkImpairment | None = None
    searches: int = 1  # differential evolution's runs from different seeds, the closest kept

    def values(self) -> dict[str, float]:
        return rig_values(self.params, self.latency_ms)


def rig_values(params: RigParams, latency_ms: float) -> dict[str, float]:
    """What identification fits, and the pendulum's natural frequency that follows, as a table row."""
    return {**{name: getattr(params, name) for name in FITTED if name != "latency_ms"}, "latency_ms": latency_ms,
            "pendulum_natural_frequency_rad_s": params.pendulum_natural_frequency_rad_s}


def candidate(base: RigParams, x: np.ndarray) -> tuple[RigParams, float]:
    """(params, latency_ms) for a point `x` of the servo search box (log scales of `base`, latency in ms)."""
    changes = {name: getattr(base, name) * math.exp(value) for name, value in zip(SERVO_BOUNDS, x[:-1])}
    length_m = changes.pop("dowel_length_m")
    return dataclasses.replace(base, **changes).with_dowel_length(length_m), float(x[-1])


def point_of(base: RigParams, params: RigParams, last: float) -> np.ndarray:
    """The point of the search box that `candidate(base, x)` turns into `params` (and `last`)."""
    x = [math.log(params.dowel_length_m / base.dowel_length_m) if name == "dowel_length_m"
         else math.log(getattr(params, name) / getattr(base, name)) for name in SERVO_BOUNDS if name != "latency_ms"]
    return np.array([*x, last])


def search_box(last: tuple[float, float] = SERVO_BOUNDS["latency_ms"]) -> list[tuple[float, float]]:
    """Log scales of the prior's fields, then `last` (the latency's ms, or the PWM phase's) as it is."""
    return [(math.log(low), math.log(high)) if name != "latency_ms" else last
            for name, (low, high) in SERVO_BOUNDS.items()]


def free_swing(recording: Recording, period_s: float):
    """The free swing at the end of an excitation episode as (times, angles), or None if too small."""

    first_free = free_from(recording.actions)
    if first_free is None:
        return None
    angles = np.asarray(recording.pendulum_rad[first_free:])
    return np.arange(len(angles)) * period_s, angles


def swing_estimates(recordings: list[Recording], period_s: float) -> tuple[float, float] | None:
    """(natural frequency rad/s, damping ratio) from every usable free swing, weighted by cycles."""

    fits = []
    for recording in recordings:
        swing = free_swing(recording, period_s)
        if swing is None:
            continue
        try:
            fits.append(identify_free_swing(*swing))
        except ConfigError:
            continue
    if not fits:
        return None
    weights = np.array([f.cycles for f in fits], dtype=float)
    return (float(np.average([f.natural_frequency_rad_s for f in fits], weights=weights)),
            float(np.average([f.damping_ratio for f in fits], weights=weights)))


def length_for_frequency(prior: RigParams, omega_rad_s: float) -> RigParams:
    """`prior` with the dowel length (and its mass, the same stock) that gives `omega_rad_s`."""
    from scipy.optimize import brentq

    low, high = 0.1, 1.5
    gap = lambda length: prior.with_dowel_length(length).pendulum_natural_frequency_rad_s - omega_rad_s  # noqa: E731
    if gap(low) * gap(high) > 0:
        return prior.with_dowel_length(low if abs(gap(low)) < abs(gap(high)) else high)
    return prior.with_dowel_length(brentq(gap, low, high, xtol=1e-5))


def fit_pendulum(recordings: list[Recording], prior: RigParams) -> RigParams:
    """Stage 1: the pendulum's length and damping from the free swings, corrected by the prior twin's."""
    period_s = prior.control_step_ms / 1000
    measured = swing_estimates(recordings, period_s)
    if measured is None:
        return prior
    twin = [dataclasses.replace(r, pendulum_rad=list(angles))
            for r, angles in zip(recordings, simulate_all(prior, PRIOR_LATENCY_MS, recordings))]
    reference = swing_estimates(twin, period_s)
    if reference is None:
        return prior
    omega = measured[0] * prior.pendulum_natural_frequency_rad_s / reference[0]
    fitted = length_for_frequency(prior, omega)
    damping = prior.pendulum_damping_n_m_s_per_rad * max(0.05, measured[1]) / max(1e-4, reference[1])
    damping = damping * fitted.pendulum_natural_frequency_rad_s / prior.pendulum_natural_frequency_rad_s
    return dataclasses.replace(fitted, pendulum_damping_n_m_s_per_rad=min(0.5, max(1e-5, damping)))


def identifying_twin(params: RigParams, latency_ms: float):
    """The realistic twin of `params` (a fixed latency, no loss) that `simulate` runs recordings on: one
    made per candidate and reset for each recording (making it costs as much as a tenth of a recording)."""
    import pendkit

    network = NetworkImpairment(LatencyModel(floor_ms=latency_ms))
    fidelity = FIDELITY_PRESETS["realistic"].replace(name="identifying", network=network)
    return pendkit.make(fidelity=fidelity, params=params, max_episode_steps=1000, **Excitation.env_kwargs())


def simulate(params: RigParams, latency_ms: float, recording: Recording, twin=None) -> np.ndarray:
    """The realistic twin of `params` (a fixed latency, no loss) run through `recording`'s actions from rest:
    the pendulum's encoder angle after each step, read with the rig's calibration offset (its reading at rest).
    `twin`: an `identifying_twin` of the same params and latency to reuse (default: one made and closed)."""
    env = twin if twin is not None else identifying_twin(params, latency_ms)
    limit = params.servo_range_rad
    arm_rad = max(-limit, min(limit, recording.start_servo_target_rad))
    env.reset(seed=0, options={"start": "rest", "arm_angle_rad": arm_rad})
    # The backend stepped directly: the recorded targets are valid and unfiltered (filter 0), and nothing the
    # env adds (its checks, observation, estimator) reaches the twin; a fifth of each step's time saved.
    backend = env.unwrapped.backend
    angles = np.empty(len(recording.actions))
    for k, action in enumerate(recording.actions):
        target = max(-1.0, min(1.0, float(np.float32(action))))
        angles[k] = backend.step(ServoCommand("continuous", target_unit=target)).pendulum_angle_rad
    if twin is None:
        env.close()
    return angles + recording.start_pendulum_rad  # a pendulum at rest hangs plumb: what it read is the offset


def simulate_all(params: RigParams, latency_ms: float, recordings: Sequence[Recording]) -> list[np.ndarray]:
    """`simulate` for each of `recordings`, on one twin."""
    twin = identifying_twin(params, latency_ms)
    try:
        return [simulate(params, latency_ms, r, twin) for r in recordings]
    finally:
        twin.close()


def matching_cost(params: RigParams, latency_ms: float, recordings: list[Recording]) -> float:
    return float(np.mean([angle_error_rad2(angles, r.pendulum_rad)
                          for r, angles in zip(recordings, simulate_all(params, latency_ms, recordings))]))


def on_device_clock(recordings: list[Recording]) -> bool:
    return all(r.device is not None and len(r.device.ms) > 2 for r in recordings)


def identify(recordings: list[Recording], prior: RigParams | None = None, max_evaluations: int = 1200,
             seed: int = 0, cost: Cost = matching_cost,
             progress: Callable[[int, float], None] | None = None, workers: int | None = None) -> Identification:
    """Fit the twin to `recordings`: the pendulum from its free swings, then the servo and latency by
    differential evolution on `cost` (default the kit's `matching_cost`; lab 09 passes the student's).
    With the kit's cost and recordings on the device's clock, the servo and its PWM phase by `replay_cost`.
    `workers`: processes replaying candidates (default one per core; a cost of the caller's own runs here)."""
    return identify_best(recordings, prior, max_evaluations, (seed,), cost, progress, workers)


def identify_best(recordings: list[Recording], prior: RigParams | None = None, max_evaluations: int = 1200,
                  seeds: Sequence[int] = (0,), cost: Cost = matching_cost,
                  progress: Callable[[int, float], None] | None = None, workers: int | None = None,
                  deadline: float = math.inf, warm: Identification | None = None) -> Identification:
    """`identify` once per seed, the fit with the lowest matching cost kept (its evaluations and seconds are
    those of all the runs): differential evolution sometimes settles in a worse fit of the same recordings,
    and the device's design on that twin then misses the rig (docs/results/transfer.md). A search after the
    first starts only when another as long as the last ends before `deadline` (a `time.time()`). `warm`: an
    earlier fit (of fewer recordings) that every search starts beside the prior."""
    if not seeds:
        raise ConfigError("identify_best needs at least one seed")
    prior = prior or RigParams()
    started = time.perf_counter()
    kits = cost is matching_cost
    replayed = kits and on_device_clock(recordings)
    cost = replay_cost if replayed else cost
    last = (0.0, prior.pwm_period_ms) if replayed else SERVO_BOUNDS["latency_ms"]
    last_prior = pwm_wait_ms(prior) if replayed else PRIOR_LATENCY_MS
    pendulum = fit_pendulum(recordings, prior)
    at = functools.partial(candidate, pendulum)
    known = [[0.0] * (len(SERVO_BOUNDS) - 1) + [last_prior]]  # the prior is one of the first candidates
    if warm is not None:
        known.append(point_of(pendulum, warm.params, warm.pwm_phase_ms if replayed else warm.latency_ms))
    count, best = 0, math.inf

    with CostPool(cost, at, recordings, workers if kits else 1) as pool:
        def costs(xs: np.ndarray) -> np.ndarray:
            nonlocal count, best
            values = pool.costs(xs)
            for value in values:
                count += 1
                best = min(best, value)
                if progress is not None:
                    progress(count, best)
            return np.asarray(values)

        runs = []
        for seed in seeds:
            began = time.time()
            runs.append(_search(costs, np.array(search_box(last)), known, max_evaluations, seed))
            if time.time() + (time.time() - began) > deadline:
                break
    best_x, best_cost = min(runs, key=lambda run: run[1])
    params, fitted_last = at(best_x)
    seconds = time.perf_counter() - started
    if not replayed:
        prior_cost = float(cost(prior, PRIOR_LATENCY_MS, recordings))
        return Identification(params, fitted_last, float(best_cost), prior_cost, count, seconds, searches=len(runs))
    prior_cost = float(cost(prior, fitted_last, recordings))
    return Identification(params, measured_latency_ms(recordings, prior), float(best_cost), prior_cost, count,
                          seconds, pwm_phase_ms=fitted_last, searches=len(runs))


def _search(costs: Callable[[np.ndarray], np.ndarray], box: np.ndarray, known: list, max_evaluations: int,
            seed: int) -> tuple[np.ndarray, float]:
    """Differential evolution over `box` (each generation's candidates costed together; the `known` points among
    the first), then a Nelder-Mead polish on a quarter of the budget: (the closest point, its cost)."""
    from scipy.optimize import differential_evolution, minimize

    dims, evolving = len(box), 3 * max_evaluations // 4  # a quarter left to polish
    members = max(5, min(10 * dims, evolving // 2))  # a small budget still gets a generation past the first
    start = np.random.default_rng(seed).uniform(box[:, 0], box[:, 1], size=(members, dims))
    start[:len(known)] = np.clip(known, box[:, 0], box[:, 1])
    generations = max(1, evolving // members - 1)
    result = differential_evolution(lambda xs: costs(xs.T), box, maxiter=generations, init=start, seed=seed,
                                    polish=False, tol=1e-6, mutation=(0.5, 1.0), recombination=0.7,
                                    vectorized=True, updating="deferred")
    polished = minimize(lambda x: float(costs(x[None, :])[0]), result.x, method="Nelder-Mead", bounds=box,
                        options={"maxfev": max_evaluations // 4, "xatol": 1e-3, "fatol": 1e-6})
    return (polished.x, float(polished.fun)) if polished.fun < result.fun else (result.x, float(result.fun))


# stage 3: the servo alone, refined about the closest fit over every recording (the loop episodes' small steps
# included), the pendulum and the PWM phase or latency kept: a local search from a good start, where a global
# search over the longer record settled short of the truth (docs/results/transfer.md)
REFINED = ("servo_speed_s_per_60deg", "servo_stall_torque_kg_cm", "servo_full_torque_error_deg",
           "servo_damping_ratio")
# each field within x/÷ this of the fit it refines; the tip (which stage 2 leaves at the prior's) as far as a
# tip reprinted with a nut inside
REFINE_SPAN = {"tip_mass_kg": 2.5}
DEFAULT_REFINE_SPAN = 1.6


def same_swing(params: RigParams, swung: RigParams) -> RigParams:
    """`params` (another tip mass, say) with the dowel length and bearing damping that keep `swung`'s free swing:
    its natural frequency and damping ratio, which the free swings read within a percent or two."""
    fitted = length_for_frequency(params, swung.pendulum_natural_frequency_rad_s)
    scale = fitted.pendulum_inertia_about_pivot_kg_m2 / swung.pendulum_inertia_about_pivot_kg_m2
    return dataclasses.replace(fitted, pendulum_damping_n_m_s_per_rad=swung.pendulum_damping_n_m_s_per_rad * scale)


def refine_servo(fit: Identification, recordings: list[Recording], prior: RigParams, max_evaluations: int = 300,
                 fields: Sequence[str] = REFINED) -> Identification:
    """`fit` with its servo's `fields` moved to the lowest matching cost over `recordings` (Nelder-Mead in log
    scales, within `REFINE_SPAN`); never a worse match of them than `fit` itself. Its `cost` and `prior_cost`
    (the `prior`'s) are then over `recordings`."""
    from scipy.optimize import minimize

    started = time.perf_counter()
    replayed = fit.pwm_phase_ms is not None and on_device_clock(recordings)
    cost = replay_cost if replayed else matching_cost
    last = fit.pwm_phase_ms if replayed else fit.latency_ms

    def params_at(x: np.ndarray) -> RigParams:
        params = dataclasses.replace(fit.params, **{name: getattr(fit.params, name) * math.exp(value)
                                                    for name, value in zip(fields, x)})
        return params if "tip_mass_kg" not in fields else same_swing(params, fit.params)

    def objective(x: np.ndarray) -> float:
        return guarded_cost(cost, params_at(x), last, recordings)

    spans = np.log([REFINE_SPAN.get(name, DEFAULT_REFINE_SPAN) for name in fields])
    start = np.zeros(len(fields))
    start_cost = objective(start)
    result = minimize(objective, start, method="Nelder-Mead", bounds=list(zip(-spans, spans)),
                      options={"maxfev": max_evaluations, "xatol": 1e-3, "fatol": 1e-7,
                               "initial_simplex": np.vstack([start, np.diag(spans) / 4])})
    best_x, best_cost = (result.x, float(result.fun)) if result.fun < start_cost else (start, start_cost)
    prior_cost = float(cost(prior, last, recordings))
    return dataclasses.replace(fit, params=params_at(best_x), cost=best_cost, prior_cost=prior_cost,
                               evaluations=fit.evaluations + result.nfev + 2,
                               seconds=fit.seconds + time.perf_counter() - started)


def measured_latency_ms(recordings: list[Recording], prior: RigParams) -> float:
    """The one-way latency from the loops the host timed during excitation (the prior's when none)."""

    loops = [loop for r in recordings for loop in r.device.loops_ms]
    if not loops:
        return PRIOR_LATENCY_MS
    return one_way_latency_ms(float(np.median(loops)), prior, EXCITATION_STREAM["streaming_period_ms"])
