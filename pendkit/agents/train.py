"""The synchronous trainer (for the twin): act, store, learn, one env step at a time."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from pendkit.agents.dqn import DqnAgent
from pendkit.agents.gru_encoder import GruEncoder
from pendkit.agents.replay import ReplayBuffer


def agent_input(observation, last_action: int, n_actions: int, encoder: GruEncoder | None) -> np.ndarray:
    """What the agent sees: the observation (and last action, one-hot) itself, or its GRU encoding."""
    one_hot = np.zeros(n_actions, dtype=np.float32)
    one_hot[last_action] = 1.0
    step = np.concatenate([np.asarray(observation, dtype=np.float32), one_hot])
    return encoder.encode(step) if encoder is not None else step


def train_sync(env, agent: DqnAgent, episodes: int, encoder: GruEncoder | None = None,
               buffer: ReplayBuffer | None = None, seed: int = 0, progress: bool = True,
               csv_path: str | Path | None = None) -> list[float]:
    """Train for `episodes`; return their returns (and write them to `csv_path` as they come)."""
    n_actions = env.action_space.n
    input_dim = env.observation_space.shape[0] + n_actions
    input_dim = encoder.output_dim if encoder is not None else input_dim
    buffer = buffer or ReplayBuffer(agent.config.buffer_capacity, input_dim, seed)
    writer, handle = None, None
    if csv_path is not None:
        Path(csv_path).parent.mkdir(parents=True, exist_ok=True)
        handle = Path(csv_path).open("w", newline="")
        writer = csv.writer(handle)
        writer.writerow(["episode", "return", "steps", "epsilon"])
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=episodes, desc="training", unit="episode")
    returns = []
    try:
        for episode in range(episodes):
            observation, _ = env.reset(seed=seed + episode)
            if encoder is not None:
                encoder.reset()
            x = agent_input(observation, 0, n_actions, encoder)
            total, steps, done = 0.0, 0, False
            while not done:
                action = agent.act(x)
                observation, reward, terminated, truncated, _ = env.step(action)
                x_next = agent_input(observation, action, n_actions, encoder)
                buffer.add(x, action, reward, x_next, terminated)
                if len(buffer) >= agent.config.learning_starts:
                    agent.update(buffer.sample(agent.config.batch_size))
                x, total, steps, done = x_next, total + reward, steps + 1, terminated or truncated
            returns.append(total)
            if writer is not None:
                writer.writerow([episode, f"{total:.4f}", steps, f"{agent.epsilon:.4f}"])
                handle.flush()
            if bar is not None:
                bar.set_postfix(ret=f"{total:.1f}")
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
        if handle is not None:
            handle.close()
    return returns
