"""The non-blocking trainer: actors keep their pace, the learner trains and publishes versioned weights,
several actors feed one buffer, and a rig actor's step timing survives a busy learner."""

import numpy as np
import pytest

torch = pytest.importorskip("torch")

import pendkit  # noqa: E402
from pendkit.agents.async_trainer import AsyncTrainer  # noqa: E402
from pendkit.agents.dqn import DqnAgent, DqnConfig  # noqa: E402
from pendkit.agents.inputs import StepInputs  # noqa: E402
from pendkit.link.virtual_rig import LocalRig  # noqa: E402


def test_two_twin_actors_feed_one_learner():
    envs = [pendkit.make(fidelity="ideal", max_episode_steps=50) for _ in range(2)]
    agent = DqnAgent(StepInputs.for_env(envs[0]).dim, 5, DqnConfig(learning_starts=100, batch_size=32))
    trainer = AsyncTrainer(agent, envs, publish_every=5)
    stats = trainer.run(seconds=3.0)
    assert all(steps > 100 for steps in stats.actor_steps)
    # every transition either reached the shared buffer, is still queued, or was dropped (and counted)
    in_flight = trainer.transitions.qsize()
    assert trainer.buffer.added + in_flight + stats.dropped_transitions == sum(stats.actor_steps)
    assert stats.learner_updates > 10 and stats.weights_published >= 2  # loose: a busy machine updates less
    assert all(max(versions) >= 1 for versions in stats.versions_used)  # actors picked up newer weights
    assert not any(thread.is_alive() for thread in trainer._threads)  # close() stopped everything


def test_a_trained_recurrent_learner_gets_whole_stretches_from_interleaved_actors():
    from pendkit.agents.learners import build_learner

    envs = [pendkit.make(fidelity="realistic", max_episode_steps=60) for _ in range(2)]
    agent, inputs = build_learner("r-dqn", envs[0], learning_starts=64, batch_size=16, update_every=1)
    trainer = AsyncTrainer(agent, envs, [inputs, build_learner("r-dqn", envs[1])[1]], publish_every=5)
    stats = trainer.run(seconds=3.0)
    assert stats.learner_updates > 10 and agent.normalizer.count == len(trainer.buffer)
    buffer = trainer.buffer
    stored = buffer.episode[:len(buffer)]
    assert {int(key) // 1_000_000 for key in stored} == {0, 1}  # both actors' steps are in the one buffer
    batch = buffer.sample(64)
    assert batch.loss_mask.sum() > 0
    for row in range(64):  # every trained step continues its stretch's episode, step by step
        kept = batch.loss_mask[row].bool()
        assert torch.all(batch.inputs[row][kept][1:, :7] == batch.next_inputs[row][kept][:-1, :7]) or kept.sum() < 2


def test_a_rig_actor_and_the_learner_both_run_on_a_virtual_rig():
    """Behaviour only: the actor steps the rig while the learner trains flat out, and each step's timing is
    recorded. How well the actor keeps its period is a timing goal: benchmarks/bench_async.py measures it."""
    rig = LocalRig()
    try:
        env = pendkit.make(backend="rig", broker=rig.url, rig=rig.rig, max_episode_steps=40,
                           rig_options={"reset_stop_s": 0.2, "observation_timeout_s": 5.0})
        config = DqnConfig(learning_starts=32, batch_size=128, hidden=(256, 256))
        agent = DqnAgent(StepInputs.for_env(env).dim, 5, config)
        trainer = AsyncTrainer(agent, [env], publish_every=5)  # the learner trains flat out meanwhile
        stats = trainer.run(seconds=4.0)
        errors_s = np.array(env.unwrapped.backend.step_period_errors_s)
        assert stats.actor_steps[0] > 0 and stats.learner_updates > 0 and stats.weights_published > 0
        assert 0 < len(errors_s) <= stats.actor_steps[0] and np.all(np.isfinite(errors_s))
        env.close()
    finally:
        rig.stop()
