"""Env steps per second of the twin against the raw physics bound, per fidelity.

The raw bound is MuJoCo's own stepping rate for the same model (mj_step in C, 1000 steps per call) over
the physics ticks the env's steps made. The env and the raw physics run in alternating slices (1000 env
steps, then raw mj_step for the same number of ticks), so that load on a shared machine hits both alike;
the ratio is the median over the slices of (raw time for the slice's ticks) / (the slice's env time).
Ticks are counted across resets (the paper-delayed preset's 0-2 extra substeps included). Goals (issue
70): ratio >= 0.9 for ideal, >= 0.8 for realistic.

    python benchmarks/bench_sim.py [--steps 20000] [--repeats 3]
"""

from __future__ import annotations

import argparse
import statistics
import time

import mujoco
import numpy as np

import pendkit

FIDELITIES = ("ideal", "paper-delayed", "realistic")
SLICE_STEPS = 1000
RAW_CHUNK = 1000


def raw_seconds(model: mujoco.MjModel, data: mujoco.MjData, ticks: int) -> float:
    """Wall time of `ticks` physics ticks stepped by MuJoCo alone, `RAW_CHUNK` per call."""
    chunks, rest = divmod(ticks, RAW_CHUNK)
    start = time.perf_counter()
    for _ in range(chunks):
        mujoco.mj_step(model, data, RAW_CHUNK)
    if rest:
        mujoco.mj_step(model, data, rest)
    return time.perf_counter() - start


def measure(fidelity: str, steps: int) -> tuple[float, float, float, float]:
    """(env steps per second, raw bound in env steps per second, median slice ratio, physics ticks per step)
    with a fixed action pattern."""
    env = pendkit.make(fidelity=fidelity)
    env.reset(seed=0)
    backend = env.unwrapped.backend
    raw_data = mujoco.MjData(backend.model)
    raw_data.qpos[1] = 2.0
    actions = np.random.default_rng(0).integers(0, 5, steps).tolist()
    env_s = raw_s = 0.0
    total_ticks, ratios = 0, []
    for first in range(0, steps, SLICE_STEPS):
        ticks, mark = 0, backend.ticks
        start = time.perf_counter()
        for action in actions[first:first + SLICE_STEPS]:
            _, _, _, truncated, _ = env.step(action)
            if truncated:
                ticks += backend.ticks - mark  # the episode's ticks; the reset's own are not env steps'
                env.reset()
                mark = backend.ticks
        slice_env_s = time.perf_counter() - start
        ticks += backend.ticks - mark
        slice_raw_s = raw_seconds(backend.model, raw_data, ticks)
        env_s, raw_s, total_ticks = env_s + slice_env_s, raw_s + slice_raw_s, total_ticks + ticks
        ratios.append(slice_raw_s / slice_env_s)
    env.close()
    return steps / env_s, steps / raw_s, statistics.median(ratios), total_ticks / steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=20000, help="env steps per measurement")
    parser.add_argument("--repeats", type=int, default=3, help="measurements per fidelity (the median is kept)")
    args = parser.parse_args()
    for fidelity in FIDELITIES:
        runs = sorted((measure(fidelity, args.steps) for _ in range(args.repeats)), key=lambda run: run[2])
        rate, raw_bound, ratio, ticks = runs[len(runs) // 2]
        print(f"fidelity={fidelity} sim_steps_per_s={rate:.0f} raw_bound_steps_per_s={raw_bound:.0f} "
              f"ratio={ratio:.2f} ticks_per_step={ticks:.2f}", flush=True)


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py (here: tests load this file alone)

    print_header()
    main()
