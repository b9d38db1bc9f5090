"""Learning on the twin: {DQN, R-DQN, TD3, R-TD3} x {ideal, paper-delayed, realistic}, several seeds, with
Stable-Baselines3's DQN on the same env as the peer (SB3 is a benchmark dependency only), and a delay sweep.
The grid runs as a `pendkit sweep` (Ray Tune, the cluster extra): one trial per learner, setting and seed,
each in its own folder under --out, so `--resume` continues a stopped run and `pendkit sweep report DIR`
tabulates it; SB3's rows run after it, in this process.

Solved: the kit's rule (`pendkit.agents.policy_rule`): at least 9 of 10 greedy episodes (5 random starts,
5 hanging still) hold |theta| < 0.3 rad for their last 200 of 500 steps. Judged every 10 training episodes
on the training starts (screened by the first), up to --max-episodes or --max-wall-s of training; the final
policy is then judged again on the reporting starts, which training never saw. One line per row:
`algo=<a> fidelity=<f> solved=<seeds>/<n> median_episodes_to_policy=<e> median_wall_s_to_policy=<s>
held_out=<seeds>/<n> policy_solved=<episodes held on the reporting starts>/<run>`.

The SB3 peer gets our DQN's settings (network, learning rate, gamma, batch, buffer, target period, epsilon
schedule, one update per step), so the wall-time ratio compares implementations, not tuning.

Two delay sweeps; their last lines say, per algo, the success rate at each delay and the largest delay
solved by at least half of the seeds:
- --sweep-delay-steps: the ideal twin seen through `ObservationDelay`, a pure delay of whole 60 ms steps;
- --sweep-delay-ms: the realistic MCU pipeline (estimated velocities, quantised encoder, safety holds) with a
  fixed observation latency and instant commands.

    python benchmarks/bench_learning.py --quick          # one seed of DQN on ideal
    python benchmarks/bench_learning.py --seeds 10 --sb3 --jobs 2
    python benchmarks/bench_learning.py --sb3-sac --sb3-only --fidelities realistic --max-episodes 300
    python benchmarks/bench_learning.py --sweep-delay-steps 0 1 2 --algos dqn r-dqn --jobs 2
    python benchmarks/bench_learning.py --sweep-delay-ms 0 50 100 150 --algos dqn r-dqn --jobs 2
"""

from __future__ import annotations

import argparse
import ast
import json
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import pendkit
from pendkit.agents.dqn import DqnConfig
from pendkit.agents.inputs import StepInputs
from pendkit.agents.learners import learner
from pendkit.agents.policy_rule import JUDGE_SEED, REPORT_SEED, RULE_MIN_HELD, RULE_STARTS, judge_policy
from pendkit.agents.td3 import Td3Config
from pendkit.sim.fidelity import Fidelity, observation_delay_fidelity
from pendkit.sim.observation_delay import ObservationDelay
from pendkit.sweep.ray_runner import run_sweep
from pendkit.sweep.report import gather, runs_record, summary_lines
from pendkit.sweep.spec import parse_spec

CHECK_EVERY = 10
EPISODE_STEPS = 500


@dataclass(frozen=True)
class StepDelay:
    """The ideal twin seen through `ObservationDelay`: a pure delay of whole 60 ms steps."""

    delay_steps: int

    @property
    def name(self) -> str:
        return f"ideal-delayed-{self.delay_steps}-steps"


def sb3_env(setting: str | Fidelity | StepDelay, algo: str = "sb3-dqn"):
    """The env of a benchmark setting for Stable-Baselines3: for DQN the kit's default observation; for SAC
    the continuous target with the observer's estimate, as `td3+estimated` (the kit's best learner) reads it."""
    kwargs = learner("td3+estimated").env_kwargs() if algo == "sb3-sac" else {}
    if isinstance(setting, StepDelay):
        return ObservationDelay(pendkit.make(fidelity="ideal", **kwargs), setting.delay_steps)
    return pendkit.make(fidelity=setting, **kwargs)


def spec_record(algos: list[str], setting_kind: str, settings: list, seeds: list[int], max_episodes: int,
                max_wall_s: float, overrides: dict | None) -> dict:
    """The benchmark's grid as a sweep spec (`pendkit sweep`): the one way trials are run and gathered."""
    return {"name": "bench-learning", "learners": algos, setting_kind: settings, "seeds": seeds,
            "budget": {"max_episodes": max_episodes, "max_wall_s": max_wall_s, "check_every": CHECK_EVERY},
            "agent": overrides or {}}


def sb3_dqn(env, seed: int, total_steps: int):
    """SB3's DQN with our DQN's settings."""
    from stable_baselines3 import DQN

    ours = DqnConfig()
    return DQN("MlpPolicy", env, seed=seed, learning_rate=ours.learning_rate, gamma=ours.gamma,
               batch_size=ours.batch_size, buffer_size=ours.buffer_capacity, learning_starts=ours.learning_starts,
               target_update_interval=ours.target_update_every, train_freq=1, gradient_steps=1,
               exploration_initial_eps=ours.epsilon_start, exploration_final_eps=ours.epsilon_end,
               exploration_fraction=ours.epsilon_decay_steps / total_steps,
               policy_kwargs={"net_arch": list(ours.hidden)}, device="cpu", verbose=0)


def sb3_sac(env, seed: int, total_steps: int):
    """SB3's SAC (automatic entropy) with our TD3's network, gamma, batch, buffer and warm-up: the peer row for
    a further continuous learner (issue 43 asks for SAC where it does better than the kit's own)."""
    from stable_baselines3 import SAC

    ours = Td3Config()
    return SAC("MlpPolicy", env, seed=seed, learning_rate=ours.critic_learning_rate, gamma=ours.gamma,
               batch_size=ours.batch_size, buffer_size=ours.buffer_capacity, learning_starts=ours.learning_starts,
               train_freq=1, gradient_steps=1, policy_kwargs={"net_arch": list(ours.hidden)}, device="cpu",
               verbose=0)


SB3_ALGOS = {"sb3-dqn": sb3_dqn, "sb3-sac": sb3_sac}


def run_sb3(fidelity: str | Fidelity, seed: int, max_episodes: int, max_wall_s: float,
            algo: str = "sb3-dqn") -> tuple[int | None, float, int]:
    from stable_baselines3.common.callbacks import BaseCallback

    total_steps = max_episodes * EPISODE_STEPS
    env, probe = sb3_env(fidelity, algo), sb3_env(fidelity, algo)
    model = SB3_ALGOS[algo](env, seed, total_steps)
    outcome: dict[str, int] = {}
    started = time.perf_counter()

    class SolvedCheck(BaseCallback):
        episodes = 0

        def _on_step(self) -> bool:
            self.episodes += int(self.locals["dones"].sum())
            if not self.locals["dones"].any() or self.episodes % CHECK_EVERY:
                return True
            if judge_sb3(probe, model, JUDGE_SEED, during_training=True).solved:
                outcome["episodes"] = self.episodes
                return False
            return time.perf_counter() - started <= max_wall_s and self.episodes < max_episodes

    model.learn(total_steps, callback=SolvedCheck())
    wall_s = time.perf_counter() - started
    return outcome.get("episodes"), wall_s, judge_sb3(probe, model, REPORT_SEED).held


class Sb3Greedy:
    """An SB3 model behind the kit's agent contract, for greedy episodes only (the rule judges it as ours)."""

    config = DqnConfig()

    def __init__(self, model) -> None:
        self.model = model

    def reset(self) -> None:
        pass

    def act(self, x, explore: bool = False):
        action = self.model.predict(x, deterministic=True)[0]
        return int(action) if np.ndim(action) == 0 else np.asarray(action, dtype=np.float32)


class RawObservation(StepInputs):
    """SB3's input: the observation alone."""

    def _make(self, observation) -> np.ndarray:
        return np.asarray(observation, dtype=np.float32)


def judge_sb3(env, model, seed: int, during_training: bool = False):
    inputs = RawObservation.for_env(env)
    return judge_policy(env, Sb3Greedy(model), inputs, seed, stop_when_decided=during_training,
                        screen=during_training)


def _one_thread() -> None:
    import torch

    torch.set_num_threads(1)  # the SB3 rows beside a sweep: two threads would fight over two cores


def setting_name(setting: str | Fidelity | StepDelay) -> str:
    return getattr(setting, "name", setting)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one seed of DQN on ideal")
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--max-episodes", type=int, default=200)
    parser.add_argument("--max-wall-s", type=float, default=600.0, help="training time per run before giving up")
    parser.add_argument("--algos", nargs="+", default=["dqn", "r-dqn", "td3", "r-td3"])
    parser.add_argument("--fidelities", nargs="+", default=["ideal", "paper-delayed", "realistic"])
    parser.add_argument("--sb3", action="store_true", help="also Stable-Baselines3 DQN (pip install '.[bench]')")
    parser.add_argument("--sb3-sac", action="store_true",
                        help="also Stable-Baselines3 SAC on the continuous target with the estimate")
    parser.add_argument("--sb3-only", action="store_true", help="only the SB3 rows (no sweep of the kit's learners)")
    parser.add_argument("--sweep-delay-ms", nargs="+", type=float, default=None,
                        help="instead of the fidelities: observation delays on the realistic pipeline")
    parser.add_argument("--sweep-delay-steps", nargs="+", type=int, default=None,
                        help="instead of the fidelities: whole-step observation delays on the ideal twin")
    parser.add_argument("--jobs", type=int, default=None, help="CPUs of the local Ray (default: all)")
    parser.add_argument("--address", default=None, help="an existing Ray cluster (auto, or ray://HOST:10001)")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--set", nargs="*", default=[], metavar="FIELD=VALUE",
                        help="agent config overrides, e.g. --set batch_size=64 update_every=8")
    parser.add_argument("--out", type=Path, default=None,
                        help="the sweep's folder (default: a temporary one); with --resume, continue it")
    parser.add_argument("--resume", action="store_true")
    parser.add_argument("--json", type=Path, default=None,
                        help="also write every run's result there (lab 08 reads the delay sweep from such a file)")
    args = parser.parse_args()
    overrides = {key: ast.literal_eval(value) for key, value in (item.split("=", 1) for item in args.set)}
    print("# python benchmarks/bench_learning.py " + " ".join(sys.argv[1:]), file=sys.stderr, flush=True)
    if args.quick:
        args.seeds, args.algos, args.fidelities, args.sb3 = 1, ["dqn"], ["ideal"], False
    if args.sweep_delay_steps is not None:
        kind, settings = "delay_steps", args.sweep_delay_steps
    elif args.sweep_delay_ms is not None:
        kind, settings = "delay_ms", args.sweep_delay_ms
    else:
        kind, settings = "fidelities", args.fidelities
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    record = spec_record(args.algos, kind, settings, seeds, args.max_episodes, args.max_wall_s, overrides)
    out = args.out or Path(tempfile.mkdtemp(prefix="bench-learning-"))
    rows = []
    if not args.sb3_only:
        run_sweep(parse_spec(record), out, args.address, args.resume, num_cpus=args.jobs, say=print)
        rows, missing = gather(out)
        for line in summary_lines(rows, missing)[len(rows):]:  # the per-trial lines were printed as they finished
            print(line, flush=True)
    sb3_algos = [algo for algo, wanted in (("sb3-dqn", args.sb3), ("sb3-sac", args.sb3_sac)) if wanted]
    if sb3_algos:
        _one_thread()
        sb3_settings = [StepDelay(k) for k in settings] if kind == "delay_steps" else settings
        if kind == "delay_ms":
            sb3_settings = [observation_delay_fidelity(delay) for delay in settings]
        for algo in sb3_algos:
            for setting in sb3_settings:
                results = [run_sb3(setting, seed, args.max_episodes, args.max_wall_s, algo) for seed in seeds]
                report_sb3(setting_name(setting), results, algo)
    if args.json is not None and rows:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        record = runs_record(rows, "python benchmarks/bench_learning.py " + " ".join(sys.argv[1:]))
        args.json.write_text(json.dumps(record, indent=1) + "\n")


def report_sb3(setting: str, results: list[tuple[int | None, float, int]], algo: str = "sb3-dqn") -> None:
    won = [(e, s) for e, s, _ in results if e is not None]
    episodes = f"{np.median([e for e, _ in won]):.0f}" if won else "nan"
    wall = f"{np.median([s for _, s in won]):.0f}" if won else "nan"
    held = [h for _, _, h in results]
    print(f"algo={algo} fidelity={setting} solved={len(won)}/{len(results)} median_episodes_to_policy={episodes} "
          f"median_wall_s_to_policy={wall} held_out={sum(h >= RULE_MIN_HELD for h in held)}/{len(held)} "
          f"policy_solved={sum(held)}/{len(RULE_STARTS) * len(held)}", flush=True)


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py (here: tests load this file alone)

    print_header()
    main()
