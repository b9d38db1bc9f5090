"""Learning on the twin: {DQN, R-DQN, TD3, R-TD3} x {ideal, paper-delayed, realistic}, several seeds, with
Stable-Baselines3's DQN on the same env as the peer (SB3 is a benchmark dependency only).

Solved: a greedy episode from the hanging start (start="rest", 500 steps) holds |theta| < 0.3 rad for its
last 200 steps. Checked every 10 training episodes, up to --max-episodes. One line per row:
`algo=<a> fidelity=<f> solved=<k>/<n> median_episodes_to_solve=<e> median_wall_s=<s>`.

    python benchmarks/bench_learning.py --quick          # one seed of DQN on ideal
    python benchmarks/bench_learning.py --seeds 10 --sb3
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import pendkit
from pendkit.agents.dqn import DqnAgent, DqnConfig
from pendkit.agents.gru_encoder import GruEncoder
from pendkit.agents.replay import ReplayBuffer
from pendkit.agents.td3 import Td3Agent, Td3Config
from pendkit.agents.train import agent_input, null_action, step_dim, train_sync

CHECK_EVERY = 10
TAIL_STEPS = 200


def solved(env, policy) -> bool:
    """Greedy episode from hanging: `policy(observation, last_action) -> action` (its own input logic)."""
    observation, info = env.reset(seed=123, options={"start": "rest"})
    action, angles, done = null_action(env.action_space), [], False
    while not done:
        action = policy(observation, action)
        observation, _, terminated, truncated, info = env.step(action)
        angles.append(abs(info["angle_from_upright_rad"]))
        done = terminated or truncated
    return len(angles) >= TAIL_STEPS and max(angles[-TAIL_STEPS:]) < 0.3


def greedy(agent, encoder, action_space):
    if encoder is not None:
        encoder.reset()
    return lambda observation, last: agent.act(agent_input(observation, last, action_space, encoder), explore=False)


def run_one(algo: str, fidelity: str, seed: int, max_episodes: int) -> tuple[int | None, float]:
    continuous = algo in ("td3", "r-td3")
    mode = "continuous" if continuous else "discrete"
    env = pendkit.make(fidelity=fidelity, action_mode=mode)
    probe = pendkit.make(fidelity=fidelity, action_mode=mode)
    encoder = GruEncoder(step_dim(env), 32, seed) if algo.startswith("r-") else None
    dim = encoder.output_dim if encoder else step_dim(env)
    agent = (Td3Agent(dim, 1, Td3Config(seed=seed)) if continuous else DqnAgent(dim, 5, DqnConfig(seed=seed)))
    buffer = ReplayBuffer(agent.config.buffer_capacity, dim, seed, action_dim=1 if continuous else None)
    started = time.perf_counter()
    for done_episodes in range(CHECK_EVERY, max_episodes + 1, CHECK_EVERY):
        train_sync(env, agent, done_episodes, encoder, buffer, seed=seed + done_episodes, progress=False)
        if solved(probe, greedy(agent, encoder, probe.action_space)):
            return done_episodes, time.perf_counter() - started
    return None, time.perf_counter() - started


def run_sb3(fidelity: str, seed: int, max_episodes: int) -> tuple[int | None, float]:
    from stable_baselines3 import DQN

    env = pendkit.make(fidelity=fidelity)
    probe = pendkit.make(fidelity=fidelity)
    model = DQN("MlpPolicy", env, seed=seed, learning_starts=500, policy_kwargs={"net_arch": [64, 64]}, verbose=0)
    started = time.perf_counter()
    for done_episodes in range(CHECK_EVERY, max_episodes + 1, CHECK_EVERY):
        model.learn(CHECK_EVERY * 500, reset_num_timesteps=False)
        if solved(probe, lambda observation, last: int(model.predict(observation, deterministic=True)[0])):
            return done_episodes, time.perf_counter() - started
    return None, time.perf_counter() - started


def report(algo: str, fidelity: str, results: list[tuple[int | None, float]]) -> None:
    solved_runs = [(e, s) for e, s in results if e is not None]
    episodes = f"{np.median([e for e, _ in solved_runs]):.0f}" if solved_runs else "nan"
    wall = f"{np.median([s for _, s in solved_runs]):.0f}" if solved_runs else "nan"
    print(f"algo={algo} fidelity={fidelity} solved={len(solved_runs)}/{len(results)} "
          f"median_episodes_to_solve={episodes} median_wall_s={wall}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one seed of DQN on ideal")
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--max-episodes", type=int, default=200)
    parser.add_argument("--algos", nargs="+", default=["dqn", "r-dqn", "td3", "r-td3"])
    parser.add_argument("--fidelities", nargs="+", default=["ideal", "paper-delayed", "realistic"])
    parser.add_argument("--sb3", action="store_true", help="also Stable-Baselines3 DQN (pip install stable-baselines3)")
    args = parser.parse_args()
    if args.quick:
        args.seeds, args.algos, args.fidelities, args.sb3 = 1, ["dqn"], ["ideal"], False
    for fidelity in args.fidelities:
        for algo in args.algos:
            report(algo, fidelity, [run_one(algo, fidelity, seed, args.max_episodes) for seed in range(args.seeds)])
        if args.sb3:
            report("sb3-dqn", fidelity, [run_sb3(fidelity, seed, args.max_episodes) for seed in range(args.seeds)])


if __name__ == "__main__":
    main()
