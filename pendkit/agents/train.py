"""The synchronous trainer (for the twin): act, store, learn, one env step at a time."""

from __future__ import annotations

import csv
from pathlib import Path

import gymnasium as gym
import numpy as np

from pendkit.agents.checkpoint import load_checkpoint, save_checkpoint
from pendkit.agents.gru_encoder import GruEncoder
from pendkit.agents.replay import ReplayBuffer


def action_features(action, action_space) -> np.ndarray:
    """The last action as the agent sees it: one-hot for discrete actions, the value for continuous ones."""
    if isinstance(action_space, gym.spaces.Discrete):
        one_hot = np.zeros(action_space.n, dtype=np.float32)
        one_hot[int(action)] = 1.0
        return one_hot
    return np.asarray(action, dtype=np.float32).reshape(action_space.shape)


def step_dim(env) -> int:
    """Size of one step's input: the observation and the last action's features."""
    return env.observation_space.shape[0] + action_features(env.action_space.sample(), env.action_space).size


def agent_input(observation, last_action, action_space, encoder: GruEncoder | None) -> np.ndarray:
    """What the agent sees: the observation and last action, or their GRU encoding (R-DQN, R-TD3)."""
    step = np.concatenate([np.asarray(observation, dtype=np.float32), action_features(last_action, action_space)])
    return encoder.encode(step) if encoder is not None else step


def null_action(action_space):
    return 0 if isinstance(action_space, gym.spaces.Discrete) else np.zeros(action_space.shape, np.float32)


def train_sync(env, agent, episodes: int, encoder: GruEncoder | None = None,
               buffer: ReplayBuffer | None = None, seed: int = 0, progress: bool = True,
               csv_path: str | Path | None = None, checkpoint_path: str | Path | None = None,
               checkpoint_every: int = 10, resume: bool = False) -> list[float]:
    """Train until `episodes` episodes are done; return all their returns. Returns are appended to
    `csv_path` as they come; with `checkpoint_path`, a checkpoint every `checkpoint_every` episodes, and
    `resume=True` continues from it."""
    space = env.action_space
    input_dim = encoder.output_dim if encoder is not None else step_dim(env)
    continuous = not isinstance(space, gym.spaces.Discrete)
    buffer = buffer or ReplayBuffer(agent.config.buffer_capacity, input_dim, seed,
                                    action_dim=space.shape[0] if continuous else None)
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
            x = agent_input(observation, null_action(space), space, encoder)
            total, steps, done = 0.0, 0, False
            while not done:
                action = agent.act(x)
                observation, reward, terminated, truncated, _ = env.step(action)
                x_next = agent_input(observation, action, space, encoder)
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
