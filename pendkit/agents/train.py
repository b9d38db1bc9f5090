"""The synchronous trainer (for the twin): act, store, learn, one env step at a time."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from pendkit.agents.checkpoint import load_checkpoint, save_checkpoint
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
               csv_path: str | Path | None = None, checkpoint_path: str | Path | None = None,
               checkpoint_every: int = 10, resume: bool = False) -> list[float]:
    """Train until `episodes` episodes are done; return all their returns. Returns are appended to
    `csv_path` as they come; with `checkpoint_path`, a checkpoint every `checkpoint_every` episodes, and
    `resume=True` continues from it."""
    n_actions = env.action_space.n
    input_dim = env.observation_space.shape[0] + n_actions
    input_dim = encoder.output_dim if encoder is not None else input_dim
    buffer = buffer or ReplayBuffer(agent.config.buffer_capacity, input_dim, seed)
    first, returns = 0, []
    if resume and checkpoint_path is not None and Path(checkpoint_path).exists():
        first, returns, _ = load_checkpoint(checkpoint_path, agent, buffer)
    writer, handle = None, None
    if csv_path is not None:
        Path(csv_path).parent.mkdir(parents=True, exist_ok=True)
        handle = Path(csv_path).open("w", newline="")  # rewritten from the checkpoint's returns: no duplicates
        writer = csv.writer(handle)
        writer.writerow(["episode", "return"])
        for episode, total in enumerate(returns):
            writer.writerow([episode, f"{total:.4f}"])
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=episodes, initial=first, desc="training", unit="episode")
    try:
        for episode in range(first, episodes):
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
                writer.writerow([episode, f"{total:.4f}"])
                handle.flush()
            if checkpoint_path is not None and (episode + 1) % checkpoint_every == 0:
                save_checkpoint(checkpoint_path, agent, buffer, episode + 1, returns, {"seed": seed})
            if bar is not None:
                bar.set_postfix(ret=f"{total:.1f}")
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
        if handle is not None:
            handle.close()
    return returns
