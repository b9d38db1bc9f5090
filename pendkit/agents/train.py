"""The synchronous trainer (for the twin): act, store, learn, one env step at a time. It relies on the agent
contract alone (`pendkit.agents.base.Agent`); what the agent sees is built by a `StepInputs`."""

from __future__ import annotations

import csv
from pathlib import Path

from pendkit.agents.base import Agent
from pendkit.agents.checkpoint import load_checkpoint, save_checkpoint
from pendkit.agents.inputs import StepInputs
from pendkit.episode import UNTIL_DONE, run_episode

__all__ = ["agent_episode", "train_sync"]


def agent_episode(env, agent: Agent, inputs: StepInputs, buffer=None, seed: int | None = None, episode_key: int = 0,
                  explore: bool = True, options: dict | None = None) -> tuple[float, list[dict]]:
    """One episode of `agent` on `env` (the kit's episode loop, `pendkit.episode.run_episode`); with a
    `buffer`, every step is stored and the agent learns as it goes. Returns the return and the per-step infos."""

    started = env.reset(seed=seed, options=options)
    now = {"x": inputs.reset(started[0]), "step": 0}
    agent.reset()
    update_every, learning = agent.config.update_every, buffer is not None
    infos: list[dict] = []

    def act(observation, state):
        if learning:
            agent.track_input(now["x"])
        return agent.act(now["x"], explore=explore)

    def learn(action, observation, reward, terminated, truncated, info) -> None:
        x, step = now["x"], now["step"]
        x_next = inputs.step(observation, action)
        if learning:
            buffer.add(x, action, reward, x_next, terminated, episode=episode_key, step=step, **agent.step_extras())
            if len(buffer) >= agent.config.learning_starts and step % update_every == 0:
                agent.update(buffer.sample(agent.config.batch_size))
        now["x"], now["step"] = x_next, step + 1
        infos.append(info)

    trace = run_episode(env, act, steps=UNTIL_DONE, started=started, on_step=learn)
    return trace.episode_return, infos


def train_sync(env, agent: Agent, episodes: int, inputs: StepInputs | None = None, buffer=None, seed: int = 0,
               progress: bool = True, csv_path: str | Path | None = None, checkpoint_path: str | Path | None = None,
               checkpoint_every: int = 10, resume: bool = False, on_episode=None) -> list[float]:
    """Train until `episodes` episodes are done; return all their returns. `inputs` says what the agent sees
    (default: observation and last action). Returns are appended to `csv_path` as they come; with
    `checkpoint_path`, a checkpoint every `checkpoint_every` episodes, and `resume=True` continues from it.
    `on_episode(episodes_done, returns)` runs after each episode, before its checkpoint; False stops training
    there (with a checkpoint)."""
    inputs = inputs if inputs is not None else StepInputs.for_env(env)
    buffer = buffer if buffer is not None else agent.new_buffer(seed)
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
            total, _ = agent_episode(env, agent, inputs, buffer, seed=seed + episode, episode_key=key)
            returns.append(total)
            if writer is not None:
                writer.writerow([episode, f"{total:.4f}"])
                handle.flush()
            stop = on_episode is not None and on_episode(episode + 1, returns) is False
            if checkpoint_path is not None and ((episode + 1) % checkpoint_every == 0 or stop):
                save_checkpoint(checkpoint_path, agent, buffer, episode + 1, returns, {"seed": seed})
            if bar is not None:
                bar.set_postfix(ret=f"{total:.1f}")
                bar.update(1)
            if stop:
                break
    finally:
        if bar is not None:
            bar.close()
        if handle is not None:
            handle.close()
    return returns
