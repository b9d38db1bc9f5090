"""Env steps per second of the twin against the raw physics bound, per fidelity.

The raw bound is MuJoCo's own stepping rate for the same model (mj_step in C, many steps per call)
divided by the physics steps in one env step. Goals: ratio >= 0.85 for ideal, >= 0.6 for realistic.

    python benchmarks/bench_sim.py [--steps 20000] [--repeats 3]
"""

from __future__ import annotations

import argparse
import time

import mujoco
import numpy as np

import pendkit

FIDELITIES = ("ideal", "paper-delayed", "realistic")


def raw_mj_steps_per_s(model: mujoco.MjModel, steps: int) -> float:
    data = mujoco.MjData(model)
    data.qpos[1] = 2.0
    chunk = 1000
    start = time.perf_counter()
    for _ in range(steps // chunk):
        mujoco.mj_step(model, data, chunk)
    return (steps // chunk) * chunk / (time.perf_counter() - start)


def env_steps_per_s(fidelity: str, steps: int) -> tuple[float, float]:
    """(env steps per second, mean physics steps per env step) with a fixed action pattern."""
    env = pendkit.make(fidelity=fidelity)
    env.reset(seed=0)
    actions = np.random.default_rng(0).integers(0, 5, steps)
    backend = env.unwrapped.backend
    tick_before = backend.ticks
    start = time.perf_counter()
    for action in actions:
        _, _, _, truncated, _ = env.step(int(action))
        if truncated:
            env.reset()
    elapsed = time.perf_counter() - start
    substeps = backend.ticks - tick_before
    env.close()
    return steps / elapsed, substeps / steps if substeps > 0 else float(backend.substeps)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=20000, help="env steps per measurement")
    parser.add_argument("--repeats", type=int, default=3, help="measurements per fidelity (best is kept)")
    args = parser.parse_args()
    model = pendkit.make().unwrapped.backend.model
    for fidelity in FIDELITIES:
        best_env, best_raw, substeps = 0.0, 0.0, 1.0
        for _ in range(args.repeats):  # interleaved so that machine load hits both alike
            rate, substeps = env_steps_per_s(fidelity, args.steps)
            best_env = max(best_env, rate)
            best_raw = max(best_raw, raw_mj_steps_per_s(model, args.steps * 12))
        raw_bound = best_raw / substeps
        print(f"fidelity={fidelity} sim_steps_per_s={best_env:.0f} raw_bound_steps_per_s={raw_bound:.0f} "
              f"ratio={best_env / raw_bound:.2f}", flush=True)


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py (here: tests load this file alone)

    print_header()
    main()
