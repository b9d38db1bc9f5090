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
import dataclasses

import gymnasium as gym
import numpy as np

from pendkit.agents.pretrained import POLICIES, train_keeping_best
from pendkit.agents.rig_suite import policy_on_rigs, preset_rigs, random_rigs, summary, validation_rigs
from pendkit.agents.runs import build_run, make_env, save_weights
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


def validation(spec, state) -> tuple[int, float]:
    """`pretrained.validation_score` for a learner told the rig."""
    together = summary(policy_on_rigs(spec.run, state, validation_rigs(spec.validation_rigs), 1, wrap=ToldTheRig))
    return together["solved"], float(together["mean_return"])


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
    _, kept = train_keeping_best(env, agent, inputs, spec, score=validation)
    run = dataclasses.replace(spec.run, randomize="")
    save_weights(args.out, agent, run, kept)
    for group, rigs in (("presets", preset_rigs()), ("held-out", random_rigs())):
        outcome = summary(policy_on_rigs(run, agent.state_dict(), rigs, args.starts, wrap=ToldTheRig))
        print(f"privileged seed={args.seed} kept={kept['chosen_at_episode']} rigs={group} "
              f"solved={outcome['solved']}/{outcome['episodes']} median_upright_s={outcome['median_upright_s']}",
              flush=True)


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py (here: tests load this file alone)

    print_header()
    main()
