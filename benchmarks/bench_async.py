"""The non-blocking trainer on a virtual rig: the actor's step-period error with the learner idle and training.

The virtual rig runs in its own process over Mosquitto, as in bench_rig_loop. Phase one runs the async
trainer with a learner that never starts learning (it only drains the transition queue); phase two runs it
with the learner training flat out (DQN, batch 128, 256x256 MLP). Goal: p99 within 0.5 ms of each other.

    python benchmarks/bench_async.py [--seconds 30]
"""

from __future__ import annotations

import argparse
import tempfile

import numpy as np

import pendkit
from pendkit.agents.async_trainer import AsyncTrainer
from pendkit.agents.dqn import DqnAgent, DqnConfig
from pendkit.agents.inputs import StepInputs
from pendkit.link.broker import MosquittoBroker
from pendkit.link.virtual_rig import virtual_rig_process


def phase(env, learning_starts: int, seconds: float) -> tuple[np.ndarray, object]:
    """Step-period errors (ms) of one async run; the backend's record is sliced to this run."""
    backend = env.unwrapped.backend
    start = len(backend.step_period_errors_s)
    config = DqnConfig(learning_starts=learning_starts, batch_size=128, hidden=(256, 256))
    agent = DqnAgent(StepInputs.for_env(env).dim, env.action_space.n, config)
    stats = AsyncTrainer(agent, [env], publish_every=20).run(seconds=seconds)
    return np.abs(np.array(backend.step_period_errors_s[start:])) * 1000, stats


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=30.0, help="length of each phase")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as work, MosquittoBroker(work) as broker, \
            virtual_rig_process(broker.url, "r01"):
        env = pendkit.make(backend="rig", rig="r01", broker=broker.url, max_episode_steps=200,
                           rig_options={"reset_stop_s": 0.5})
        env.reset(seed=0)  # warm up: the first connection and reset are not what either phase measures
        for _ in range(20):
            env.step(2)
        idle_ms, idle = phase(env, learning_starts=10**9, seconds=args.seconds)
        training_ms, training = phase(env, learning_starts=64, seconds=args.seconds)
        env.close()
    for name, errors, stats in (("idle", idle_ms, idle), ("training", training_ms, training)):
        print(f"learner={name} actor_steps={stats.actor_steps[0]} learner_updates={stats.learner_updates} "
              f"weights_published={stats.weights_published} dropped_transitions={stats.dropped_transitions} "
              f"step_error_p50_ms={np.percentile(errors, 50):.3f} step_error_max_ms={errors.max():.3f}")
    print(f"p99_idle_ms={np.percentile(idle_ms, 99):.3f} p99_training_ms={np.percentile(training_ms, 99):.3f}")


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py (here: tests load this file alone)

    print_header()
    main()
