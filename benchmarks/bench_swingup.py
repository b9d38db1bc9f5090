"""Swing-up and balance with the classical controller from seeded random starts (the authors' reset).

Upright means |theta| < 0.3 rad from some step until the episode's end (500 steps, 30 s); the time to
upright is the first step of that final run. The env runs in continuous mode with its action filter off
(filter_coefficient=0): the swing-up moves the servo target freely and the LQR smooths its own targets
with the paper's c = 0.85 (see pendkit.control.lqr). `--env-filter` keeps the env's filter instead.
The goal on realistic is 100/100 and a median of at most 1.4 s (the paper's R-DQN on the real rig).

    python benchmarks/bench_swingup.py [--starts 100] [--fidelity ideal realistic] [--env-filter]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import pendkit
from pendkit.control.swingup import SwingUpController
from pendkit.episode import run_episode, time_to_upright_s


def run(fidelity: str, starts: int, env_filter: bool) -> tuple[list[float], int]:
    times, failures = [], 0
    for seed in range(starts):
        env = pendkit.make(action_mode="continuous", fidelity=fidelity,
                           **({} if env_filter else {"filter_coefficient": 0.0}))
        trace = run_episode(env, SwingUpController.for_env(env), seed=seed)
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
    parser.add_argument("--env-filter", action="store_true", help="keep the env's c=0.85 action filter")
    args = parser.parse_args()
    for fidelity in args.fidelity:
        started = time.perf_counter()
        times, failures = run(fidelity, args.starts, args.env_filter)
        median = f"{np.median(times):.2f}" if times else "nan"
        p90 = f"{np.percentile(times, 90):.2f}" if times else "nan"
        print(f"env_filter={args.env_filter} wall_s={time.perf_counter() - started:.0f} "
              f"fidelity={fidelity} swingup_success={args.starts - failures}/{args.starts} "
              f"median_time_to_upright_s={median} p90_time_to_upright_s={p90}", flush=True)


if __name__ == "__main__":
    main()
