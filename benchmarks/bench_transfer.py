"""Sim-to-real across servos: does a policy trained on the twin work on a servo it was not trained on?

The paper's authors found that policies did not transfer between servos. Two trainings of the same learner
on the realistic twin with the same budget: one on the default servo preset, one with domain randomisation
(`pendkit.sim.randomize`: servo, latency and masses drawn anew every episode). Every 20 episodes each is
evaluated greedy from the hanging start on every servo preset (solved: |theta| < 0.3 rad for the last 200
of 500 steps); a training stops when >= 4 presets are solved or its episodes (or time) are up. One line per training:

    transfer algo=<a> training=<one-preset|randomized> presets_solved=<k>/5 episodes=<e> wall_s=<s> solved=<names>

    python benchmarks/bench_transfer.py --algo r-dqn --max-episodes 400 --jobs 2
"""

from __future__ import annotations

import argparse
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context

import pendkit
from pendkit.agents.train import make_buffer, run_episode, train_sync
from pendkit.agents.variants import build_learner, inputs_for, variant
from pendkit.features import holds_upright
from pendkit.rig import SERVO_PRESETS, RigParams
from pendkit.sim.randomize import DomainRandomization

RANDOMIZED = "servo,latency,masses"
CHECK_EVERY = 20
TAIL_STEPS = 200
GOAL_PRESETS = 4


def presets_solved(algo: str, agent, seed: int) -> list[str]:
    solved = []
    for name in sorted(SERVO_PRESETS):
        env = pendkit.make(fidelity="realistic", params=RigParams.preset(name), **variant(algo).env_kwargs())
        _, infos = run_episode(env, agent, inputs_for(variant(algo), env, seed), seed=123, explore=False,
                               options={"start": "rest"})
        angles = [abs(info["angle_from_upright_rad"]) for info in infos]
        if holds_upright(angles, TAIL_STEPS):
            solved.append(name)
    return solved


def run(algo: str, randomized: bool, seed: int, max_episodes: int, max_wall_s: float, verbose: bool) -> tuple:
    import torch

    torch.set_num_threads(1)
    env = pendkit.make(fidelity="realistic", **variant(algo).env_kwargs())
    if randomized:
        env = DomainRandomization(env, RANDOMIZED, seed)
    agent, inputs = build_learner(algo, env, seed)
    buffer = make_buffer(agent, inputs.dim, env.action_space, seed)
    started, episodes, best = time.perf_counter(), 0, []
    while time.perf_counter() - started < max_wall_s and episodes < max_episodes:
        train_sync(env, agent, CHECK_EVERY, inputs, buffer, seed=seed + episodes, progress=False)
        episodes += CHECK_EVERY
        solved = presets_solved(algo, agent, seed)
        best = solved if len(solved) > len(best) else best
        if verbose:
            print(f"    {algo} randomized={randomized} episodes={episodes} solved={solved} "
                  f"wall_s={time.perf_counter() - started:.0f}", file=sys.stderr, flush=True)
        if len(solved) >= GOAL_PRESETS:
            break
    return algo, randomized, solved, best, episodes, time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--algo", default="r-dqn")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--max-episodes", type=int, default=400)
    parser.add_argument("--max-wall-s", type=float, default=1800.0)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--verbose", action="store_true")
    args = parser.parse_args()
    work = [(args.algo, randomized, args.seed, args.max_episodes, args.max_wall_s, args.verbose)
            for randomized in (False, True)]
    with ProcessPoolExecutor(args.jobs, mp_context=get_context("spawn")) as pool:
        for algo, randomized, solved, best, episodes, wall in pool.map(run, *zip(*work)):
            print(f"transfer algo={algo} training={'randomized' if randomized else 'one-preset'} "
                  f"presets_solved={len(solved)}/{len(SERVO_PRESETS)} best_presets_solved={len(best)} "
                  f"episodes={episodes} wall_s={wall:.0f} solved={','.join(solved) or '-'}", flush=True)


if __name__ == "__main__":
    main()
