"""The paper's non-blocking trainer (Bohm et al. 2022): actors keep the control period while a learner
thread trains. Actors and learner meet only through bounded queues: transitions one way, version-tagged
weights the other. An actor never waits for the learner: it takes the newest weights if there are any,
and if the transition queue is full it drops the transition (counted) rather than block. Several actors
(rigs, twins) feed one learner's replay buffer.
"""

from __future__ import annotations

import copy
import queue
import sys
import threading
import time
from dataclasses import dataclass, field

from pendkit.agents.base import Agent
from pendkit.agents.inputs import StepInputs
from pendkit.episode import UNTIL_DONE, run_episode


@dataclass
class AsyncStats:
    actor_steps: list[int] = field(default_factory=list)
    episodes: list[list[float]] = field(default_factory=list)  # returns per actor
    learner_updates: int = 0
    weights_published: int = 0
    versions_used: list[set[int]] = field(default_factory=list)
    dropped_transitions: int = 0
    learner_wait_s: float = 0.0


class AsyncTrainer:
    """`run(seconds)` with one actor thread per env and a learner thread; `close()` stops them."""

    def __init__(self, agent: Agent, envs: list, inputs: list[StepInputs] | None = None, buffer=None,
                 transition_queue_size: int = 1000, publish_every: int = 20, seed: int = 0) -> None:
        """`inputs`: one `StepInputs` per env (what the agent sees; default: observation and last action)."""
        self.agent, self.envs = agent, envs
        self.inputs = inputs or [StepInputs.for_env(env) for env in envs]
        self.buffer = buffer if buffer is not None else agent.new_buffer(seed)
        self.transitions: queue.Queue = queue.Queue(maxsize=transition_queue_size)
        self.weights: list[queue.Queue] = [queue.Queue(maxsize=1) for _ in envs]
        self.publish_every, self.seed = publish_every, seed
        self.stop = threading.Event()
        self.stats = AsyncStats(actor_steps=[0] * len(envs), episodes=[[] for _ in envs],
                                versions_used=[set() for _ in envs])
        self._threads: list[threading.Thread] = []
        self.max_episodes: int | None = None
        self._started_episodes = 0
        self._episode_lock = threading.Lock()

    def run(self, seconds: float, episodes: int | None = None) -> AsyncStats:
        """Train for `seconds` of wall time, or until the actors have finished `episodes` episodes together
        (a rig's budget: each actor then starts no episode beyond it)."""
        self.max_episodes = episodes
        # Python hands the interpreter between threads every 5 ms by default: long enough to make an
        # actor that wakes for its deadline wait behind the learner. 1 ms keeps the actors on time.
        switch_interval = sys.getswitchinterval()
        sys.setswitchinterval(0.001)
        try:
            return self._run(seconds)
        finally:
            sys.setswitchinterval(switch_interval)

    def _run(self, seconds: float) -> AsyncStats:
        self._threads = [threading.Thread(target=self._learn, daemon=True, name="pendkit-learner")]
        self._threads += [threading.Thread(target=self._act, args=(k,), daemon=True, name=f"pendkit-actor-{k}")
                          for k in range(len(self.envs))]
        for thread in self._threads:
            thread.start()
        deadline = time.monotonic() + seconds
        while not self.stop.wait(min(0.05, max(0.0, deadline - time.monotonic()))):
            if time.monotonic() >= deadline or self._budget_spent():
                break
        self.close()
        return self.stats

    def _start_episode(self) -> bool:
        """Whether the episode budget allows one more episode (counted when it starts)."""
        with self._episode_lock:
            if self.max_episodes is not None and self._started_episodes >= self.max_episodes:
                return False
            self._started_episodes += 1
            return True

    def _budget_spent(self) -> bool:
        return self.max_episodes is not None and sum(map(len, self.stats.episodes)) >= self.max_episodes

    def close(self) -> None:
        self.stop.set()
        for thread in self._threads:
            thread.join(timeout=10)

    # --- the learner: take in transitions, train continuously, publish weights ---
    def _learn(self) -> None:
        version = 0
        while not self.stop.is_set():
            while not self.transitions.empty():
                self._store(self.transitions.get_nowait())
            if len(self.buffer) < self.agent.config.learning_starts:
                waited = time.monotonic()
                try:  # not enough to learn from yet: wait for transitions
                    self._store(self.transitions.get(timeout=0.05))
                except queue.Empty:
                    pass
                self.stats.learner_wait_s += time.monotonic() - waited
                continue
            self.agent.update(self.buffer.sample(self.agent.config.batch_size))
            self.stats.learner_updates += 1
            if self.stats.learner_updates % self.publish_every == 0:
                version += 1
                policy = self.agent.policy_state()
                for mailbox in self.weights:  # replace what the actor has not taken yet: newest only
                    try:
                        mailbox.get_nowait()
                    except queue.Empty:
                        pass
                    mailbox.put_nowait((version, policy))
                self.stats.weights_published += 1

    def _store(self, transition: tuple) -> None:
        x, action, reward, x_next, done, extras = transition
        self.agent.track_input(x)
        self.buffer.add(x, action, reward, x_next, done, **extras)

    # --- an actor: act at the env's pace, never wait for the learner ---
    def _act(self, k: int) -> None:
        env, inputs = self.envs[k], self.inputs[k]
        actor = copy.deepcopy(self.agent)  # its own policy copy: the learner's updates never race its forward pass
        now = {"version": 0}

        def act(observation, state):
            try:  # the newest weights the learner sent, if any since the last step
                now["version"], policy = self.weights[k].get_nowait()
                actor.load_policy(policy)
            except queue.Empty:
                pass
            self.stats.versions_used[k].add(now["version"])
            return actor.act(now["x"])

        def stepped(action, observation, reward, terminated, truncated, info) -> None:
            x_next = inputs.step(observation, action)
            extras = {"episode": 1_000_000 * k + now["episode"], "step": now["step"], **actor.step_extras()}
            try:
                self.transitions.put_nowait((now["x"], action, reward, x_next, terminated, extras))
            except queue.Full:
                self.stats.dropped_transitions += 1
            now.update(x=x_next, total=now["total"] + reward, step=now["step"] + 1)
            self.stats.actor_steps[k] += 1

        episode = 0
        while not self.stop.is_set() and self._start_episode():
            started = env.reset(seed=self.seed + 1000 * k + episode)
            now.update(x=inputs.reset(started[0]), total=0.0, step=0, episode=episode)
            actor.reset()
            run_episode(env, act, started=started, steps=UNTIL_DONE, on_step=stepped,
                        should_stop=lambda state: "stopped" if self.stop.is_set() else None)
            self.stats.episodes[k].append(now["total"])
            episode += 1
