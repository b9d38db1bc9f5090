"""Is it inferring the rig or learning over many rigs that holds r-dqn-robust back? The same recipe with one
factor changed: the agent is *told* the rig (its parameters, network and calibration error, scaled to the
training ranges, appended to every observation), as a privileged teacher in rapid motor adaptation is. If
this learner also plateaus near a fifth of the goal, inference from the history is not what limits it.
Validation and the kept checkpoint as `python -m pendkit.agents.pretrained r-dqn-robust`; then the kept
checkpoint's greedy episodes (rest + `--starts` random starts) on the presets and the held-out rigs, each
told its own parameters.

    python benchmarks/bench_privileged.py --seed 0 --out runs/privileged-s0.pt   # long-running: ~25 min
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import time

import gymnasium as gym
import numpy as np

from pendkit.agents.pretrained import POLICIES
from pendkit.agents.rig_suite import preset_rigs, random_rigs, rig_env, summary, validation_rigs
from pendkit.agents.runs import build_run, evaluate_agent, make_env, save_weights
from pendkit.agents.train import train_sync
from pendkit.rig import RigParams
from pendkit.sim.fidelity import resolve_fidelity
from pendkit.sim.randomize import SERVO_FIELDS
from pendkit.sim.randomize import TRAINING_RANGES as R


def rig_features(env) -> np.ndarray:
    """What the privileged learner is told about the rig `env` simulates, each about 0..1 over training."""
    params, fidelity, default = env.params, resolve_fidelity(env.backend.fidelity), RigParams()
    network = fidelity.network
    values = [(getattr(params, f), getattr(R, f)) for f in SERVO_FIELDS] + [
        (params.tip_mass_kg / default.tip_mass_kg, R.tip_mass_scale),
        (params.dowel_length_m, R.dowel_length_m),
        (params.pendulum_damping_n_m_s_per_rad / default.pendulum_damping_n_m_s_per_rad, R.pendulum_damping_scale),
        (params.servo_min_counts, R.servo_min_counts), (params.servo_max_counts, R.servo_max_counts),
        (fidelity.encoder_residual_offset_counts, R.residual_offset_counts),
        (network.latency.median_ms, R.latency_median_ms), (network.command_loss_pct, R.loss_pct)]
    return np.array([(v - lo) / (hi - lo) for v, (lo, hi) in values], dtype=np.float32)


class ToldTheRig(gym.ObservationWrapper):
    """Appends `rig_features` of the (possibly just redrawn) rig to every observation."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        extra = len(rig_features(env.unwrapped))
        low, high = env.observation_space.low, env.observation_space.high
        self.observation_space = gym.spaces.Box(np.concatenate([low, np.full(extra, -np.inf, np.float32)]),
                                                np.concatenate([high, np.full(extra, np.inf, np.float32)]),
                                                dtype=np.float32)

    def observation(self, observation):
        return np.concatenate([np.asarray(observation, np.float32), rig_features(self.env.unwrapped)])


def on_rigs(spec, state, rigs, starts: int, seed: int = 10_000) -> dict:
    outcomes = {}
    for name, rig in rigs.items():
        env = ToldTheRig(rig_env(rig, spec))
        _, agent, inputs = build_run(spec, env)
        agent.load_state_dict(state)
        outcomes[name] = evaluate_agent(env, agent, inputs, 1 + starts, seed, ["rest"] + ["random"] * starts)
        env.close()
    return outcomes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", required=True, help="where the kept checkpoint is written (.pt)")
    parser.add_argument("--episodes", type=int, default=None, help="default: r-dqn-robust's")
    parser.add_argument("--starts", type=int, default=5)
    args = parser.parse_args()
    spec = POLICIES["r-dqn-robust"]
    spec = dataclasses.replace(spec, run=dataclasses.replace(spec.run, seed=args.seed),
                               episodes=args.episodes or spec.episodes)
    env = ToldTheRig(make_env(spec.run))
    _, agent, inputs = build_run(spec.run, env)
    buffer = agent.new_buffer(spec.run.seed)
    returns, best, started = [], None, time.perf_counter()
    while len(returns) < spec.episodes:
        returns += train_sync(env, agent, spec.check_every, inputs, buffer=buffer,
                              seed=spec.run.seed * 7919 + len(returns))
        checked = summary(on_rigs(spec.run, agent.state_dict(), validation_rigs(spec.validation_rigs), 1))
        score = (checked["solved"], checked["mean_return"])
        print(f"episodes={len(returns)} validation_solved={score[0]} validation_return={score[1]:.0f} "
              f"train_return={sum(returns[-125:]) / 125:.0f} wall_s={time.perf_counter() - started:.0f}",
              flush=True)
        if best is None or score > best[0]:
            best = (score, len(returns), copy.deepcopy(agent.state_dict()))
    run = dataclasses.replace(spec.run, randomize="")
    save_weights(args.out, agent, run, {"chosen_at_episode": best[1], "validation_solved": best[0][0]})
    for group, rigs in (("presets", preset_rigs()), ("held-out", random_rigs())):
        outcome = summary(on_rigs(run, best[2], rigs, args.starts))
        print(f"privileged seed={args.seed} kept={best[1]} rigs={group} solved={outcome['solved']}/"
              f"{outcome['episodes']} median_upright_s={outcome['median_upright_s']}", flush=True)


if __name__ == "__main__":
    main()
