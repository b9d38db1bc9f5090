"""The synchronous trainer (for the twin): act, store, learn, one env step at a time."""

from __future__ import annotations

import csv
from pathlib import Path

import gymnasium as gym
import numpy as np

from pendkit.agents.checkpoint import load_checkpoint, save_checkpoint
from pendkit.agents.gru_encoder import GruEncoder
from pendkit.agents.inputs import StepInputs, action_features, null_action
from pendkit.agents.replay import ReplayBuffer

__all__ = ["action_features", "agent_input", "make_buffer", "null_action", "run_episode", "step_dim", "train_sync"]


def step_dim(env) -> int:
    """Size of one step's input: the observation and the last action's features."""
    return StepInputs.for_env(env).step_dim


def agent_input(observation, last_action, action_space, encoder: GruEncoder | None) -> np.ndarray:
    """The observation and last action, or their fixed-GRU encoding (one step; see `StepInputs` for more)."""
    step = np.concatenate([np.asarray(observation, dtype=np.float32), action_features(last_action, action_space)])
    return encoder.encode(step) if encoder is not None else step


def make_buffer(agent, input_dim: int, action_space, seed: int = 0):
    """The replay buffer this agent learns from: stretches of episodes for a recurrent agent."""
    if getattr(agent, "recurrent", False):
        return agent.new_buffer(seed)
    continuous = not isinstance(action_space, gym.spaces.Discrete)
    return ReplayBuffer(agent.config.buffer_capacity, input_dim, seed,
                        action_dim=action_space.shape[0] if continuous else None)


def as_inputs(env, inputs):
    """`inputs` if it builds step inputs itself (`reset`, `step`, `dim`: a `StepInputs` or a lab's own);
    otherwise observation and last action, through `inputs` if it is a fixed GruEncoder (the ablation)."""
    if all(hasattr(inputs, name) for name in ("reset", "step", "dim")):
        return inputs
    return StepInputs.for_env(env, 1, inputs)


def run_episode(env, agent, inputs: StepInputs, buffer=None, seed: int | None = None, episode_key: int = 0,
                explore: bool = True, options: dict | None = None) -> tuple[float, list[dict]]:
    """One episode; with a `buffer`, every step is stored and the agent learns as it goes.
    Returns the return and the per-step infos."""
    observation, info = env.reset(seed=seed, options=options)
    x = inputs.reset(observation)
    recurrent = getattr(agent, "recurrent", False)
    if recurrent:
        agent.reset()
    update_every = getattr(agent.config, "update_every", 1)
    total, step, done, infos = 0.0, 0, False, []
    while not done:
        if buffer is not None and hasattr(agent, "track_input"):
            agent.track_input(x)
        action = agent.act(x, explore=explore)
        observation, reward, terminated, truncated, info = env.step(action)
        x_next = inputs.step(observation, action)
        if buffer is not None:
            if recurrent:
                buffer.add(x, action, reward, x_next, terminated, hidden=agent.hidden_before,
                           episode=episode_key, step=step)
            else:
                buffer.add(x, action, reward, x_next, terminated)
            if len(buffer) >= agent.config.learning_starts and step % update_every == 0:
                agent.update(buffer.sample(agent.config.batch_size))
        x, total, step, done = x_next, total + reward, step + 1, terminated or truncated
        infos.append(info)
    return total, infos


def train_sync(env, agent, episodes: int, inputs: StepInputs | GruEncoder | None = None, buffer=None, seed: int = 0,
               progress: bool = True, csv_path: str | Path | None = None, checkpoint_path: str | Path | None = None,
               checkpoint_every: int = 10, resume: bool = False, encoder: GruEncoder | None = None) -> list[float]:
    """Train until `episodes` episodes are done; return all their returns. `inputs` says what the agent sees
    (default: observation and last action). Returns are appended to `csv_path` as they come; with
    `checkpoint_path`, a checkpoint every `checkpoint_every` episodes, and `resume=True` continues from it."""
    inputs = as_inputs(env, inputs if inputs is not None else encoder)
    buffer = buffer if buffer is not None else make_buffer(agent, inputs.dim, env.action_space, seed)
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
            key = seed * 100_000 + episode  # unique per episode, also across resumed and repeated calls
            total, _ = run_episode(env, agent, inputs, buffer, seed=seed + episode, episode_key=key)
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
