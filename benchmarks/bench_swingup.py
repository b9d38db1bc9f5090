"""Swing-up and balance with the classical controller from seeded random starts (the authors' reset).

Upright means |theta| < 0.3 rad from some step until the episode's end (500 steps, 30 s); the time to
upright is the first step of that final run. The env runs in continuous mode with its action filter off
(filter_coefficient=0): the swing-up moves the servo target freely and the LQR smooths its own targets
with the paper's c = 0.85 (see pendkit.control.lqr). `--env-filter` keeps the env's filter instead.
The goal on realistic is 100/100, a median of at most 1.4 s (the paper's R-DQN on the real rig) and a p90
of at most 2.5 s. Rows: `energy` (pendkit.control.swingup) and `trajopt` (the minimum-time plan tracked by
time-varying LQR, pendkit.control.tracking). The bench also prints the optimiser's lower bound from the
hanging rest: the fewest steps any full-left/full-right sequence needs to reach the catch set, and
whether python-control's solve_ocp, with free targets, finds one step fewer.

    python benchmarks/bench_swingup.py [--starts 100] [--fidelity ideal realistic] [--controller energy trajopt]
                                       [--env-filter] [--no-bound] [--bound-iterations 40] [--plot PNG]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import pendkit
from pendkit.control.trajopt import StepModel, fastest_bang_bang, initial_state, polish_with_ocp
from pendkit.deploy.controllers import CONTROLLER_NAMES, controller_named
from pendkit.episode import run_episode, time_to_upright_s


def run(fidelity: str, starts: int, env_filter: bool, controller: str = "energy") -> tuple[list[float], int]:
    times, failures = [], 0
    for seed in range(starts):
        env = pendkit.make(action_mode="continuous", fidelity=fidelity,
                           **({} if env_filter else {"filter_coefficient": 0.0}))
        trace = run_episode(env, controller_named(controller).host(env), seed=seed)
        upright_at = time_to_upright_s(trace.pendulum_from_upright_rad, env.unwrapped.dt)
        if upright_at is None:
            failures += 1
        else:
            times.append(upright_at)
    return times, failures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--starts", type=int, default=100)
    parser.add_argument("--fidelity", nargs="+", default=["ideal", "realistic"])
    parser.add_argument("--controller", nargs="+", default=list(CONTROLLER_NAMES), choices=CONTROLLER_NAMES)
    parser.add_argument("--env-filter", action="store_true", help="keep the env's c=0.85 action filter")
    parser.add_argument("--no-bound", action="store_true", help="skip the lower bound")
    parser.add_argument("--bound-iterations", type=int, default=40, help="SLSQP iterations for one step fewer")
    parser.add_argument("--plot", help="write a box plot of the times to upright to this PNG")
    args = parser.parse_args()
    if not args.no_bound:
        print_lower_bound(args.bound_iterations)
    rows = {}
    for fidelity in args.fidelity:
        for controller in args.controller:
            started = time.perf_counter()
            times, failures = run(fidelity, args.starts, args.env_filter, controller)
            rows[f"{controller}\n{fidelity}"] = times
            median = f"{np.median(times):.2f}" if times else "nan"
            p90 = f"{np.percentile(times, 90):.2f}" if times else "nan"
            print(f"controller={controller} env_filter={args.env_filter} wall_s={time.perf_counter() - started:.0f} "
                  f"fidelity={fidelity} swingup_success={args.starts - failures}/{args.starts} "
                  f"median_time_to_upright_s={median} p90_time_to_upright_s={p90}", flush=True)
    if args.plot:
        plot_times(rows, args.plot, args.starts)


def plot_times(rows: dict[str, list[float]], path: str, starts: int) -> None:
    from matplotlib.figure import Figure

    figure = Figure(figsize=(7, 3.2), layout="constrained")
    axis = figure.subplots()
    axis.boxplot(list(rows.values()), tick_labels=list(rows), whis=(0, 90))
    axis.axhline(1.4, color="#CC79A7", linestyle="--", lw=1, label="paper's R-DQN on the rig (1.4 s)")
    axis.set_ylabel("time to upright (s)")
    axis.set_title(f"Swing-up from {starts} random starts (whiskers: min to p90)")
    axis.legend(loc="upper right", fontsize=8)
    figure.savefig(path, dpi=110)


def print_lower_bound(iterations: int = 40) -> None:
    """Fewest steps from the hanging rest to the catch set, on the realistic twin's model (its delay)."""
    step_model = StepModel.for_env(pendkit.make(action_mode="continuous", fidelity="realistic"))
    rest = initial_state(pendulum_rad=0.0, pendulum_velocity_rad_s=1e-3)  # exactly at rest nothing moves it
    for switches in (3, 4, 5, 6):
        plan = fastest_bang_bang(step_model, rest, max_switches=switches)
        print(f"lower_bound switches<={switches} bang_bang_s={plan.duration_s:.2f} "
              f"solve_s={plan.solve_s:.2f} sequences={plan.notes['sequences']}", flush=True)
    started = time.perf_counter()
    fewer = polish_with_ocp(step_model, plan, steps=len(plan.targets_rad) - 1, max_iterations=iterations)
    print(f"lower_bound solve_ocp_one_step_fewer={'found' if fewer else 'none'} "
          f"({(len(plan.targets_rad) - 1) * step_model.period_s:.2f} s, {iterations} SLSQP iterations, "
          f"{time.perf_counter() - started:.0f} s)", flush=True)


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py (here: tests load this file alone)

    print_header()
    main()
