"""Learning on the twin: {DQN, R-DQN, TD3, R-TD3} x {ideal, paper-delayed, realistic}, several seeds, with
Stable-Baselines3's DQN on the same env as the peer (SB3 is a benchmark dependency only), and a delay sweep.

Solved: a greedy episode from the hanging start (start="rest", 500 steps) holds |theta| < 0.3 rad for its
last 200 steps. Checked every 10 training episodes, up to --max-episodes or --max-wall-s of training. One
line per row: `algo=<a> fidelity=<f> solved=<k>/<n> median_episodes_to_solve=<e> median_wall_s=<s>`.

The SB3 peer gets our DQN's settings (network, learning rate, gamma, batch, buffer, target period, epsilon
schedule, one update per step), so the wall-time ratio compares implementations, not tuning.

Two delay sweeps; their last lines say, per algo, the success rate at each delay and the largest delay
solved by at least half of the seeds:
- --sweep-delay-steps: the ideal twin seen through `ObservationDelay`, a pure delay of whole 60 ms steps;
- --sweep-delay-ms: the realistic MCU pipeline (estimated velocities, quantised encoder, safety holds) with a
  fixed observation latency and instant commands.

    python benchmarks/bench_learning.py --quick          # one seed of DQN on ideal
    python benchmarks/bench_learning.py --seeds 10 --sb3 --jobs 2
    python benchmarks/bench_learning.py --sweep-delay-steps 0 1 2 --algos dqn r-dqn --jobs 2
    python benchmarks/bench_learning.py --sweep-delay-ms 0 50 100 150 --algos dqn r-dqn --jobs 2
"""

from __future__ import annotations

import argparse
import ast
import json
import re
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path

import numpy as np

import pendkit
from pendkit.agents.dqn import DqnConfig
from pendkit.agents.learners import inputs_for
from pendkit.agents.runs import RunSpec, build_run, greedy_episode, make_env, solved
from pendkit.agents.train import train_sync
from pendkit.features import UPRIGHT_RAD, holds_upright
from pendkit.sim.fidelity import Fidelity, observation_delay_fidelity
from pendkit.sim.observation_delay import ObservationDelay

CHECK_EVERY = 10
TAIL_STEPS = 200
EPISODE_STEPS = 500


@dataclass(frozen=True)
class StepDelay:
    """The ideal twin seen through `ObservationDelay`: a pure delay of whole 60 ms steps."""

    delay_steps: int

    @property
    def name(self) -> str:
        return f"ideal-delayed-{self.delay_steps}-steps"


def sb3_env(setting: str | Fidelity | StepDelay):
    """The env of a benchmark setting for Stable-Baselines3's DQN: the kit's default observation."""
    if isinstance(setting, StepDelay):
        return ObservationDelay(pendkit.make(fidelity="ideal"), setting.delay_steps)
    return pendkit.make(fidelity=setting)


def run_spec(learner: str, setting: str | Fidelity | StepDelay, seed: int, overrides: dict | None = None) -> RunSpec:
    """The run of a benchmark row (a Fidelity object names the sweeps' own fidelities)."""
    if isinstance(setting, StepDelay):
        return RunSpec(learner, "ideal", seed, delay_steps=setting.delay_steps, agent=overrides or {})
    return RunSpec(learner, setting, seed, agent=overrides or {})


def held(env, agent, inputs) -> bool:
    """The kit's solved rule on a greedy episode from hanging (seed 123)."""
    return solved(greedy_episode(env, agent, inputs)[1])


def run_one(algo: str, fidelity: str | Fidelity | StepDelay, seed: int, max_episodes: int,
            max_wall_s: float, overrides: dict | None = None, verbose: bool = False) -> tuple[int | None, float]:
    """Episodes and seconds until solved, or (None, seconds spent)."""
    if algo == "sb3-dqn":
        return run_sb3(fidelity, seed, max_episodes, max_wall_s)
    spec = run_spec(algo, fidelity, seed, overrides)
    env, agent, inputs = build_run(spec)
    probe = make_env(spec)
    probe_inputs = inputs_for(algo, probe, seed)
    buffer = agent.new_buffer(seed)
    started = time.perf_counter()
    for done_episodes in range(CHECK_EVERY, max_episodes + 1, CHECK_EVERY):
        returns = train_sync(env, agent, CHECK_EVERY, inputs, buffer, seed=seed + done_episodes, progress=False)
        if verbose:
            print(f"    {algo} {setting_name(fidelity)} seed={seed} episodes={done_episodes} "
                  f"mean_return={np.mean(returns):.0f} wall_s={time.perf_counter() - started:.0f}",
                  file=sys.stderr, flush=True)
        if held(probe, agent, probe_inputs):
            return done_episodes, time.perf_counter() - started
        if time.perf_counter() - started > max_wall_s:
            break
    return None, time.perf_counter() - started


def run_sb3(fidelity: str | Fidelity, seed: int, max_episodes: int, max_wall_s: float) -> tuple[int | None, float]:
    from stable_baselines3 import DQN
    from stable_baselines3.common.callbacks import BaseCallback

    ours = DqnConfig()
    total_steps = max_episodes * EPISODE_STEPS
    env, probe = sb3_env(fidelity), sb3_env(fidelity)
    model = DQN("MlpPolicy", env, seed=seed, learning_rate=ours.learning_rate, gamma=ours.gamma,
                batch_size=ours.batch_size, buffer_size=ours.buffer_capacity, learning_starts=ours.learning_starts,
                target_update_interval=ours.target_update_every, train_freq=1, gradient_steps=1,
                exploration_initial_eps=ours.epsilon_start, exploration_final_eps=ours.epsilon_end,
                exploration_fraction=ours.epsilon_decay_steps / total_steps,
                policy_kwargs={"net_arch": list(ours.hidden)}, device="cpu", verbose=0)
    outcome: dict[str, int] = {}
    started = time.perf_counter()

    class SolvedCheck(BaseCallback):
        episodes = 0

        def _on_step(self) -> bool:
            self.episodes += int(self.locals["dones"].sum())
            if not self.locals["dones"].any() or self.episodes % CHECK_EVERY:
                return True
            if solved_sb3(probe, model):
                outcome["episodes"] = self.episodes
                return False
            return time.perf_counter() - started <= max_wall_s and self.episodes < max_episodes

    model.learn(total_steps, callback=SolvedCheck())
    return outcome.get("episodes"), time.perf_counter() - started


def solved_sb3(env, model) -> bool:
    observation, _ = env.reset(seed=123, options={"start": "rest"})
    angles, done = [], False
    while not done:
        observation, _, terminated, truncated, info = env.step(int(model.predict(observation, deterministic=True)[0]))
        angles.append(abs(info["angle_from_upright_rad"]))
        done = terminated or truncated
    return holds_upright(angles, TAIL_STEPS)


def _one_thread() -> None:
    import torch

    torch.set_num_threads(1)  # one process per core beats threads fighting over two cores


def setting_name(setting: str | Fidelity | StepDelay) -> str:
    return getattr(setting, "name", setting)


def _print_run(algo: str, fidelity: str | Fidelity, seed: int, result: tuple[int | None, float]) -> None:
    print(f"  run algo={algo} fidelity={setting_name(fidelity)} seed={seed} episodes={result[0]} "
          f"wall_s={result[1]:.0f}", file=sys.stderr, flush=True)


def run_rows(rows: list[tuple[str, str | Fidelity]], seeds: int, max_episodes: int, max_wall_s: float,
             jobs: int, overrides: dict | None = None, verbose: bool = False,
             first_seed: int = 0) -> list[list[tuple[int | None, float]]]:
    """Each row's results, seed by seed; a row's line is printed as soon as its last seed is done."""
    work = [(algo, fidelity, seed, max_episodes, max_wall_s, overrides, verbose) for algo, fidelity in rows
            for seed in range(first_seed, first_seed + seeds)]
    pool = (ProcessPoolExecutor(jobs, mp_context=get_context("spawn"), initializer=_one_thread)
            if jobs > 1 else None)
    try:
        futures = [pool.submit(run_one, *args) for args in work] if pool else None
        flat: list[tuple[int | None, float]] = []
        for index, args in enumerate(work):
            flat.append(futures[index].result() if futures else run_one(*args))
            _print_run(args[0], args[1], args[2], flat[-1])
            if len(flat) % seeds == 0:
                report(args[0], args[1], flat[-seeds:])
    finally:
        if pool is not None:
            pool.shutdown(cancel_futures=True)
    return [flat[i * seeds:(i + 1) * seeds] for i in range(len(rows))]


def report(algo: str, fidelity: str | Fidelity, results: list[tuple[int | None, float]]) -> None:
    solved_runs = [(e, s) for e, s in results if e is not None]
    episodes = f"{np.median([e for e, _ in solved_runs]):.0f}" if solved_runs else "nan"
    wall = f"{np.median([s for _, s in solved_runs]):.0f}" if solved_runs else "nan"
    print(f"algo={algo} fidelity={setting_name(fidelity)} solved={len(solved_runs)}/{len(results)} "
          f"median_episodes_to_solve={episodes} median_wall_s={wall}", flush=True)


def sweep_summary(algo: str, delays_ms: list[float], results: list[list[tuple[int | None, float]]]) -> None:
    rates = [sum(e is not None for e, _ in row) / len(row) for row in results]
    holding = [delay for delay, rate in zip(delays_ms, rates) if rate >= 0.5]
    rate_text = " ".join(f"{delay:g}ms={rate:.2f}" for delay, rate in zip(delays_ms, rates))
    print(f"sweep algo={algo} success_rate: {rate_text} largest_delay_solved_ms={max(holding, default=float('nan')):g}",
          flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one seed of DQN on ideal")
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--max-episodes", type=int, default=200)
    parser.add_argument("--max-wall-s", type=float, default=600.0, help="training time per run before giving up")
    parser.add_argument("--algos", nargs="+", default=["dqn", "r-dqn", "td3", "r-td3"])
    parser.add_argument("--fidelities", nargs="+", default=["ideal", "paper-delayed", "realistic"])
    parser.add_argument("--sb3", action="store_true", help="also Stable-Baselines3 DQN (pip install '.[bench]')")
    parser.add_argument("--sweep-delay-ms", nargs="+", type=float, default=None,
                        help="instead of the fidelities: observation delays on the realistic pipeline")
    parser.add_argument("--sweep-delay-steps", nargs="+", type=int, default=None,
                        help="instead of the fidelities: whole-step observation delays on the ideal twin")
    parser.add_argument("--jobs", type=int, default=1, help="runs in parallel, one process and thread each")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--set", nargs="*", default=[], metavar="FIELD=VALUE",
                        help="agent config overrides, e.g. --set batch_size=64 update_every=8")
    parser.add_argument("--verbose", action="store_true", help="a line per 10 episodes of every run (stderr)")
    parser.add_argument("--json", type=Path, default=None,
                        help="also write every run's result there (lab 08 reads the delay sweep from such a file)")
    parser.add_argument("--json-from-log", type=Path, default=None, metavar="LOG",
                        help="instead of running: rebuild --json from the 'run' lines of an earlier sweep's log "
                             "(a sweep stopped early keeps every delay all of whose runs finished); give the "
                             "run's --max-episodes and --max-wall-s too")
    args = parser.parse_args()
    if args.json_from_log is not None:
        json_from_log(args.json_from_log, args.json or Path("sweep.json"), args)
        return
    overrides = {key: ast.literal_eval(value) for key, value in (item.split("=", 1) for item in args.set)}
    _one_thread()  # also for --jobs 1: two benchmarks side by side must not fight with two threads each
    print("# python benchmarks/bench_learning.py " + " ".join(sys.argv[1:]), file=sys.stderr, flush=True)
    if args.quick:
        args.seeds, args.algos, args.fidelities, args.sb3 = 1, ["dqn"], ["ideal"], False
    delays_ms = args.sweep_delay_ms
    if args.sweep_delay_steps is not None:
        fidelities = [StepDelay(steps) for steps in args.sweep_delay_steps]
        step_ms = pendkit.make().unwrapped.dt * 1000
        delays_ms = [steps * step_ms for steps in args.sweep_delay_steps]
    elif args.sweep_delay_ms is not None:
        fidelities = [observation_delay_fidelity(delay) for delay in args.sweep_delay_ms]
    else:
        fidelities = args.fidelities
    algos = args.algos + (["sb3-dqn"] if args.sb3 else [])
    rows = [(algo, fidelity) for fidelity in fidelities for algo in algos]
    results = run_rows(rows, args.seeds, args.max_episodes, args.max_wall_s, args.jobs, overrides, args.verbose,
                       args.first_seed)
    for algo in algos:  # one summary line per agent
        mine = [(setting_name(f), r) for (a, f), r in zip(rows, results) if a == algo]
        print(f"summary algo={algo} " + " ".join(f"{name}={sum(e is not None for e, _ in r)}/{len(r)}"
                                                  for name, r in mine), flush=True)
    if delays_ms is not None:
        for algo in algos:
            sweep_summary(algo, delays_ms, [r for (a, _), r in zip(rows, results) if a == algo])
    if args.json is not None:
        write_json(args.json, rows, results, delays_ms, args)


RUN_LINE = re.compile(r"run algo=(\S+) fidelity=ideal-delayed-(\d+)-steps seed=(\d+) episodes=(\S+) wall_s=(\d+)")


def json_from_log(log: Path, path: Path, args) -> None:
    """The --json file of a whole-step sweep from its log: the delays where every algorithm has every seed."""
    runs: dict[tuple[str, int], list[tuple[int | None, float]]] = {}
    for match in RUN_LINE.finditer(log.read_text()):
        algo, steps, _, episodes, wall = match.groups()
        runs.setdefault((algo, int(steps)), []).append((None if episodes == "None" else int(episodes), float(wall)))
    algos = list(dict.fromkeys(algo for algo, _ in runs))
    seeds = max(len(r) for r in runs.values())
    steps = sorted({s for _, s in runs if all(len(runs.get((a, s), [])) == seeds for a in algos)})
    rows = [(algo, StepDelay(s)) for s in steps for algo in algos]
    step_ms = pendkit.make().unwrapped.dt * 1000
    first = log.read_text().splitlines()[0]
    command = first.removeprefix("# ") if first.startswith("# ") else "python benchmarks/bench_learning.py (a sweep)"
    write_json(path, rows, [runs[(a, d.delay_steps)] for a, d in rows], [s * step_ms for s in steps], args,
               command=f"{command}; rebuilt from its log with --json-from-log")


def write_json(path: Path, rows, results, delays_ms, args, command: str | None = None) -> None:
    """Every run's (episodes to solve or null, seconds), by algorithm and setting; a sweep's delays in ms."""
    record = {"command": command or "python benchmarks/bench_learning.py " + " ".join(sys.argv[1:]),
              "solved_rule": f"greedy from hanging, |theta| < {UPRIGHT_RAD:g} rad for the last {TAIL_STEPS} of "
                             f"{EPISODE_STEPS} steps, checked every {CHECK_EVERY} episodes",
              "max_episodes": args.max_episodes, "max_wall_s": args.max_wall_s,
              "delays_ms": delays_ms,
              "runs": [{"algo": algo, "setting": setting_name(setting),
                        "episodes": [e for e, _ in result], "wall_s": [round(s, 1) for _, s in result]}
                       for (algo, setting), result in zip(rows, results)]}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
