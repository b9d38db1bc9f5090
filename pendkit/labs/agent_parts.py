"""Students' own learning pieces inside the kit's agents, with their contract checks. Lab 07: their
exploration schedule chooses when to explore, their target is what the network regresses to, and their
loss gives the gradient (`DqnAgent` takes all three as callables). Lab 08: their augmented state is what
the delay-aware agent sees. A wrong piece changes what the agent learns, which is the point.

The pieces are plain numpy functions, as the lab asks for them:
- `epsilon(step, start, end, decay_steps) -> float`
- `td_target(rewards, dones, next_q_online, next_q_target, gamma, double) -> (batch,) array`
- `loss(errors, delta) -> elementwise array`; its gradient is taken numerically (central differences), so
  a loss written in numpy trains the torch network as it is written.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numpy as np
import torch

from pendkit.agents.dqn import DqnAgent, DqnConfig
from pendkit.agents.inputs import StepInputs
from pendkit.errors import ConfigError

DERIVATIVE_STEP = 1e-4


class StudentCodeError(ConfigError):
    """A student's function broke its contract (raised, or returned the wrong shape or a non-number)."""


@dataclass(frozen=True)
class StudentParts:
    """A student's functions; None keeps the kit's own."""

    epsilon: Callable | None = None
    td_target: Callable | None = None
    loss: Callable | None = None

    def hooks(self) -> dict:
        """`DqnAgent`'s keyword arguments: each given piece behind its contract check."""
        hooks = {}
        if self.epsilon is not None:
            hooks["epsilon"] = partial(call_epsilon, self.epsilon)
        if self.td_target is not None:
            hooks["target"] = partial(call_td_target, self.td_target)
        if self.loss is not None:
            hooks["loss"] = partial(student_loss, self.loss)
        return hooks


def student_dqn(observation_dim: int, n_actions: int, config: DqnConfig | None = None,
                parts: StudentParts | None = None) -> DqnAgent:
    """The kit's DQN with a student's pieces in place of its own."""
    return DqnAgent(observation_dim, n_actions, config, **(parts or StudentParts()).hooks())


def call_epsilon(fn: Callable, step: int, start: float, end: float, decay_steps: int) -> float:
    try:
        value = float(fn(step, start, end, decay_steps))
    except Exception as error:
        raise StudentCodeError(f"your epsilon({step}, {start}, {end}, {decay_steps}) raised {error!r}") from error
    if not (math.isfinite(value) and 0.0 <= value <= 1.0):
        raise StudentCodeError(f"your epsilon({step}, ...) returned {value}: a probability must be in [0, 1]")
    return value


def call_td_target(fn: Callable, rewards: torch.Tensor, dones: torch.Tensor, next_q_online: torch.Tensor,
                   next_q_target: torch.Tensor, gamma: float, double: bool) -> torch.Tensor:
    arrays = [t.detach().numpy().astype(np.float64) for t in (rewards, dones, next_q_online, next_q_target)]
    try:
        out = np.asarray(fn(*arrays, gamma, double), dtype=np.float64)
    except Exception as error:
        axes = (": next_q has one row per transition and one column per action; take the max or argmax over "
                "axis=1" if "shape" in str(error) or "broadcast" in str(error) else "")
        raise StudentCodeError(f"your td_target raised {error!r} on a batch of {len(rewards)}{axes}") from error
    if out.shape != (len(rewards),):
        raise StudentCodeError(f"your td_target returned shape {out.shape}; expected ({len(rewards)},), one "
                               "target per transition")
    if not np.all(np.isfinite(out)):
        raise StudentCodeError("your td_target returned a non-finite target (nan or inf)")
    return torch.from_numpy(out.astype(np.float32))


class _NumpyLoss(torch.autograd.Function):
    """Mean of a numpy elementwise loss; the gradient by central differences of the same function."""

    @staticmethod
    def forward(ctx, errors: torch.Tensor, fn, delta: float) -> torch.Tensor:
        e = errors.detach().numpy().astype(np.float64)
        values = _elementwise(fn, e, delta)
        step = DERIVATIVE_STEP * np.maximum(1.0, np.abs(e))
        slope = (_elementwise(fn, e + step, delta) - _elementwise(fn, e - step, delta)) / (2 * step)
        ctx.save_for_backward(torch.from_numpy(slope.astype(np.float32)))
        return torch.tensor(float(values.mean()), dtype=errors.dtype)

    @staticmethod
    def backward(ctx, grad_output):
        (slope,) = ctx.saved_tensors
        return grad_output * slope / slope.numel(), None, None


def _elementwise(fn: Callable, errors: np.ndarray, delta: float) -> np.ndarray:
    try:
        out = np.asarray(fn(errors.copy(), delta), dtype=np.float64)
    except Exception as error:
        raise StudentCodeError(f"your loss raised {error!r} on {errors.size} errors") from error
    if out.shape != errors.shape:
        raise StudentCodeError(f"your loss returned shape {out.shape} for errors of shape {errors.shape}: "
                               "it must be elementwise")
    if not np.all(np.isfinite(out)):
        raise StudentCodeError("your loss returned a non-finite value")
    return out


def student_loss(fn: Callable, errors: torch.Tensor, delta: float) -> torch.Tensor:
    return _NumpyLoss.apply(errors, fn, delta)


class StudentInputs:
    """What a delay-aware agent sees, built by a student's `augmented_state(observation, recent_actions,
    n_actions)` (lab 08): `recent_actions` holds the last `actions_seen` action indices, newest first (0, the
    stop, before the first action). Same interface as `pendkit.agents.inputs.StepInputs`."""

    def __init__(self, fn: Callable, observation_dim: int, n_actions: int, actions_seen: int) -> None:
        self.fn, self.n_actions, self.actions_seen = fn, n_actions, actions_seen
        self.dim = observation_dim + n_actions * actions_seen
        self._recent: list[int] = []

    def reset(self, observation) -> np.ndarray:
        self._recent = [0] * self.actions_seen
        return self._make(observation)

    def step(self, observation, action) -> np.ndarray:
        self._recent = [int(action), *self._recent[:-1]]
        return self._make(observation)

    def _make(self, observation) -> np.ndarray:
        try:
            out = np.asarray(self.fn(np.array(observation, dtype=np.float32), list(self._recent), self.n_actions),
                             dtype=np.float32)
        except Exception as error:
            raise StudentCodeError(f"your augmented_state raised {error!r}") from error
        if out.shape != (self.dim,):
            raise StudentCodeError(f"your augmented_state returned shape {out.shape}; expected ({self.dim},): "
                                   f"the observation then {self.actions_seen} one-hot actions of {self.n_actions}")
        if not np.all(np.isfinite(out)):
            raise StudentCodeError("your augmented_state returned a non-finite value")
        return out


def train_with_parts(env, parts: StudentParts, episodes: int, seed: int = 0, learning_starts: int = 500,
                     inputs=None, progress: bool = True):
    """Train the kit's DQN with a student's pieces on `env`: (agent, returns), or (None, None) with a
    one-line note when a piece is not written yet or breaks (the note says which and how). Torch runs on one
    thread here: as fast for these small networks, and the same run gives the same curve on any laptop
    (several threads sum in a varying order, and a 50-episode run is chaotic enough to show it). A progress
    bar shows the episodes (a training cell runs for minutes)."""
    from pendkit.agents.train import train_sync

    inputs = inputs or StepInputs.for_env(env)
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        agent = student_dqn(inputs.dim, env.action_space.n, DqnConfig(seed=seed, learning_starts=learning_starts),
                            parts)
        returns = run_or_note(train_sync, env, agent, episodes, inputs, seed=seed, progress=progress)
    finally:
        torch.set_num_threads(threads)
    return (agent, returns) if returns is not None else (None, None)


def train_until_rule(env, parts: StudentParts, max_episodes: int, seed: int = 0, learning_starts: int = 500,
                     check_every: int = 10, report: Callable[[str], None] = print):
    """Lab 07's training: the kit's DQN with a student's pieces, judged every `check_every` episodes by the
    kit's rule on the training starts (screened by its first episode, hanging still), stopping once it passes
    (as `lab07-claim.yaml` measures it). Each check is reported in one line. Returns (agent, returns,
    episodes to the rule or None), or (None, None, None) with a note when a piece is missing or broken."""
    from pendkit.agents.policy_rule import train_until_solved

    inputs = StepInputs.for_env(env)
    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # as train_with_parts: the same curve on any laptop
    try:
        agent = student_dqn(inputs.dim, env.action_space.n, DqnConfig(seed=seed, learning_starts=learning_starts),
                            parts)
        outcome = run_or_note(train_until_solved, env, agent, inputs, max_episodes, check_every, seed=seed,
                              on_check=lambda episodes, _, verdict: report(check_line(episodes, verdict)))
    finally:
        torch.set_num_threads(threads)
    return (agent, *outcome) if outcome is not None else (None, None, None)


def realistic_run(parts: StudentParts, seed: int = 0, episodes: int = 150, report: Callable[[str], None] = print):
    """Lab 07's reflection 2: the training cell's run (at most `episodes`, the rule every 10, each check reported)
    on the realistic twin instead of the ideal one, with a student's pieces; the outcome in one line at the end.
    Returns what `train_until_rule` returns."""
    import pendkit

    env = pendkit.make(fidelity="realistic", max_episode_steps=500)
    agent, returns, solved_at = train_until_rule(env, parts, episodes, seed, report=report)
    if returns is not None:
        report(f"realistic twin, seed {seed}: " + (
            f"a policy that holds (the rule) after {solved_at} episodes" if solved_at else
            f"no policy that holds in {len(returns)} episodes (mean return of the last 10: "
            f"{np.mean(returns[-10:]):.0f})"))
    return agent, returns, solved_at


def check_line(episodes: int, verdict) -> str:
    """One check of the rule in words: what the greedy episodes run so far did."""
    if len(verdict.starts) == 1 and not verdict.held:
        return (f"after {episodes:3d} episodes: the first greedy episode (hanging still) did not hold "
                f"(return {verdict.evaluation.returns[0]:.0f}); the other nine are not run")
    kinds = ", ".join(f"{'hanging still' if kind == 'rest' else 'random starts'} {count}"
                      for kind, count in verdict.held_by_start().items())
    outcome = "passes: training stops here" if verdict.solved else "two missed: not yet"
    return f"after {episodes:3d} episodes: held {verdict.held} of {len(verdict.starts)} ({kinds}): {outcome}"


FIXED_BUDGET_POLICY = Path(__file__).resolve().parents[1] / "data" / "lab07_fixed_budget_q.json"


def fixed_budget_policy(env) -> DqnAgent:
    """Lab 07's second policy to judge: the kit's DQN on the ideal twin trained a fixed 80 episodes (seed 4 of
    `benchmarks/sweeps/lab07-fixed.yaml`) instead of until the rule passed. Its Q-network's weights are stored
    exactly (float32, base64) in pendkit/data; written by `benchmarks/studies/lab07_student_seeds.py --export`."""
    import base64
    import json

    record = json.loads(FIXED_BUDGET_POLICY.read_text())
    inputs = StepInputs.for_env(env)
    agent = DqnAgent(inputs.dim, env.action_space.n, DqnConfig(seed=record["seed"]))
    agent.q.load_state_dict({name: torch.from_numpy(np.frombuffer(base64.b64decode(tensor["float32"]), dtype=np.float32)
                                                     .reshape(tensor["shape"]).copy())
                             for name, tensor in record["q"].items()})
    return agent


def run_or_note(fn: Callable, *args, **kwargs):
    """Call `fn`; if a student's piece inside it is missing or broken, print one line saying so and
    return None (a demo cell then shows what it can without it)."""
    try:
        return fn(*args, **kwargs)
    except StudentCodeError as error:
        if isinstance(error.__cause__, NotImplementedError):
            print(f"not run: {str(error).split(' raised ')[0].replace('your ', '')} is not implemented yet")
        else:
            print(f"not run: {error}")
        return None


def kit_epsilon(step: int, start: float, end: float, decay_steps: int) -> float:
    """The kit's exploration schedule (`DqnAgent.epsilon`) in numpy, as lab 07 asks for it."""
    return start + min(1.0, step / decay_steps) * (end - start)


def kit_huber(errors, delta: float) -> np.ndarray:
    """The kit's Huber loss (torch's `huber_loss`, elementwise) in numpy, as lab 07 asks for it."""
    size = np.abs(np.asarray(errors, dtype=float))
    return np.where(size <= delta, 0.5 * size**2, delta * (size - 0.5 * delta))


def kit_td_target(rewards, dones, next_q_online, next_q_target, gamma: float, double: bool) -> np.ndarray:
    """The kit's (double) DQN target in numpy, as lab 07 asks for it."""
    rewards, dones = np.asarray(rewards, dtype=float), np.asarray(dones, dtype=float)
    next_q_online, next_q_target = np.asarray(next_q_online, dtype=float), np.asarray(next_q_target, dtype=float)
    pick = next_q_online.argmax(axis=1) if double else next_q_target.argmax(axis=1)
    return rewards + gamma * (1 - dones) * next_q_target[np.arange(len(rewards)), pick]


def unlike_the_kit(parts: StudentParts) -> list[str]:
    """The names of a student's pieces ("epsilon", "td_target", "huber") that give other numbers than the kit's
    on a few inputs that tell them apart (a piece that raises counts as unlike; a missing one is the kit's)."""
    rng = np.random.default_rng(7)
    rewards, dones = rng.normal(size=6), np.array([0.0, 1.0, 0.0, 0.0, 1.0, 0.0])
    online, target = rng.normal(size=(6, 5)), rng.normal(size=(6, 5))
    errors = np.linspace(-4.0, 4.0, 17)
    probes = {"epsilon": (parts.epsilon, kit_epsilon, [(step, 1.0, 0.05, 1000) for step in (0, 250, 999, 1000, 5000)]),
              "td_target": (parts.td_target, kit_td_target,
                            [(rewards, dones, online, target, 0.99, double) for double in (True, False)]),
              "huber": (parts.loss, kit_huber, [(errors, delta) for delta in (1.0, 0.5)])}
    unlike = []
    for name, (theirs, kit, calls) in probes.items():
        if theirs is None:
            continue
        try:
            same = all(np.allclose(np.asarray(theirs(*(np.copy(a) if isinstance(a, np.ndarray) else a for a in call)),
                                              dtype=float), kit(*call)) for call in calls)
        except Exception:  # noqa: BLE001 (the student's code: unlike the kit's however it fails)
            same = False
        if not same:
            unlike.append(name)
    return unlike


PIECE_ROLE = {"epsilon": "it decides when the agent explores",
              "huber": "its slope is the gradient the network follows, so a wrong loss trains the network wrong"}


def training_said(returns, myopic, solved_at: int | None, unlike: list[str]) -> str | None:
    """What lab 07's training cell says under its curves: the cause its student can act on. The contrast (no
    future in the target) trains with the kit's schedule and loss, so a curve at or below it points at the
    target only when the student's target is unlike the kit's; with a target like the kit's, a run without a
    policy points at the piece that is unlike (the loss or the schedule), and with all three like the kit's, at
    the seed. None when there is nothing to say (a policy that holds, from pieces like the kit's)."""
    episodes = len(returns)
    if "td_target" in unlike:
        said = curve_against_myopic(returns, myopic)
        if said:
            return said
        if solved_at is None:
            return (f"no policy in {episodes} episodes, and your td_target gives other targets than the kit's: its "
                    "check above says how")
        return "a policy that holds, though your td_target gives other targets than the kit's (its check above)"
    others = [name for name in ("huber", "epsilon") if name in unlike]
    if others:
        named = " and ".join(f"your {name} ({PIECE_ROLE[name]})" for name in others)
        if solved_at is None:
            return (f"your td_target agrees with the kit's, but {named} gives other numbers than the kit's: "
                    "its check above says how; the curve with no future used the kit's loss and schedule")
        return f"a policy that holds, though {named} gives other numbers than the kit's (its check above)"
    if solved_at is None:
        return (f"your three pieces agree with the kit's: this seed did not reach a policy that holds in {episodes} "
                "episodes (seeds vary): try another seed")
    return None


def random_starts_held(env, agent, inputs, count: int, seed: int) -> list[bool]:
    """Whether each of `count` greedy episodes from the authors' random starts held (the rule's measure), episode
    k from seed `seed + k`: lab 07 asks the student's verdict about random starts alone."""
    from pendkit.agents.runs import greedy_episode, judged_episode

    held = []
    for k in range(count):
        total, infos = greedy_episode(env, agent, inputs, seed=seed + k, start="random")
        held += judged_episode([info["angle_from_upright_rad"] for info in infos], env.unwrapped.dt, total).solved
    return held


def curve_against_myopic(returns, myopic, window: int = 10) -> str | None:
    """What lab 07 says of a learning curve beside the one with no future in its target (over the episodes
    both ran): None when it is neither that curve nor below it."""
    returns, myopic = np.asarray(returns, dtype=float), np.asarray(myopic, dtype=float)
    returns = returns[:len(myopic)]  # the contrast may train fewer episodes: compare the same episodes
    if returns.shape == myopic.shape and np.allclose(returns, myopic):
        return ("your curve is the myopic one, episode for episode: does your target add the future "
                "(gamma times the next state's value)?")
    window = min(window, len(returns), len(myopic))
    yours, none = float(np.mean(returns[-window:])), float(np.mean(myopic[-window:]))
    if yours < none - 0.1 * abs(none):
        last = len(returns)
        return (f"your curve ends below the one with no future at all ({yours:.0f} against {none:.0f} over episodes "
                f"{last - window + 1}-{last}, the last the two share): your target teaches the agent to avoid the "
                "top. Look for the future's sign "
                "(reward plus gamma times it), done flags the wrong way round, or a max over the wrong axis.")
    return None
