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

from pendkit.agents.learners import inputs_for
from pendkit.agents.runs import RunSpec, build_run, greedy_episode, make_env, solved
from pendkit.agents.train import train_sync
from pendkit.rig import SERVO_PRESETS

RANDOMIZED = "servo,latency,masses"
CHECK_EVERY = 20
GOAL_PRESETS = 4


def presets_solved(algo: str, agent, seed: int) -> list[str]:
    """The presets on which a greedy episode from hanging meets the kit's solved rule."""
    held = []
    for name in sorted(SERVO_PRESETS):
        env = make_env(RunSpec(algo, "realistic", seed, preset=name))
        if solved(greedy_episode(env, agent, inputs_for(algo, env, seed))[1]):
            held.append(name)
    return held


def run(algo: str, randomized: bool, seed: int, max_episodes: int, max_wall_s: float, verbose: bool) -> tuple:
    import torch

    torch.set_num_threads(1)
    env, agent, inputs = build_run(RunSpec(algo, "realistic", seed, randomize=RANDOMIZED if randomized else ""))
    buffer = agent.new_buffer(seed)
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
