"""A learned policy on a hidden rig's true twin (everything known: its network, its encoder's calibration
error, the observer designed for its true parameters), judged by the kit's rule: can a rig that no classical
design swings up be learned at all? docs/results/robust.md.

    python benchmarks/studies/true_twin.py --rig hidden-02 --seed 0 --episodes 400
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rig", default="hidden-02", help="one of bench_transfer's hidden rigs")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--episodes", type=int, default=400)
    parser.add_argument("--learner", default="td3+estimated")
    args = parser.parse_args()

    import torch
    from bench_transfer import adapt_rigs

    import pendkit
    from pendkit.agents.policy_rule import REPORT_SEED, judge_policy, train_until_solved
    from pendkit.agents.runs import RunSpec, build_run, evaluate_agent
    from pendkit.sim.fidelity import FIDELITY_PRESETS

    torch.set_num_threads(1)
    rig = dict(adapt_rigs(6))[args.rig]
    fidelity = FIDELITY_PRESETS["realistic"].replace(name="true-twin", network=rig.network,
                                                     encoder_residual_offset_counts=rig.residual_offset_counts)
    env = pendkit.make(fidelity=fidelity, params=rig.params, action_mode="continuous", features="estimated",
                       observer_params=rig.params)
    _, agent, inputs = build_run(RunSpec(args.learner, "realistic", seed=args.seed), env)
    started = time.perf_counter()
    returns, solved_at = train_until_solved(env, agent, inputs, args.episodes, check_every=20, seed=args.seed,
                                            progress=False)
    verdict = judge_policy(env, agent, inputs, REPORT_SEED)
    rest = evaluate_agent(env, agent, inputs, 10, start="rest")
    print(f"true_twin rig={args.rig} learner={args.learner} seed={args.seed} episodes={len(returns)} "
          f"solved_at={solved_at} {verdict.summary()} rest_{rest.summary()} "
          f"last_returns={[round(r) for r in returns[-5:]]} wall_s={time.perf_counter() - started:.0f}")


if __name__ == "__main__":
    main()
