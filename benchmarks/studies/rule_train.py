"""A learner trained on one fidelity with its checkpoint kept by the kit's rule, then judged on starts its
checks never saw (the rule's reporting starts, 20 random, 10 hanging): docs/results/learning.md.

    python benchmarks/studies/rule_train.py --learner dqn+estimated --seed 0 --episodes 600 --check-every 50
"""

from __future__ import annotations

import argparse
import json
import time


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--learner", default="dqn+estimated")
    parser.add_argument("--fidelity", default="realistic")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--episodes", type=int, default=600)
    parser.add_argument("--check-every", type=int, default=50)
    parser.add_argument("--agent", default="{}", help="agent settings as JSON, e.g. '{\"hidden\": [128, 128]}'")
    parser.add_argument("--out", default=None, help="write the kept weights here")
    args = parser.parse_args()

    import torch

    from pendkit.agents.policy_rule import REPORT_SEED, judge_policy
    from pendkit.agents.pretrained import PretrainedSpec, rule_score, train_keeping_best
    from pendkit.agents.runs import RunSpec, build_run, evaluate_agent, save_weights

    torch.set_num_threads(1)
    spec = PretrainedSpec(RunSpec(args.learner, args.fidelity, seed=args.seed, agent=json.loads(args.agent)),
                          args.episodes, check_every=args.check_every, kept_by="rule")
    env, agent, inputs = build_run(spec.run)
    started = time.perf_counter()
    _, chosen = train_keeping_best(env, agent, inputs, spec, rule_score)
    if args.out:
        save_weights(args.out, agent, spec.run, chosen)
    verdict = judge_policy(env, agent, inputs, REPORT_SEED)
    random = evaluate_agent(env, agent, inputs, 20, start="random")
    rest = evaluate_agent(env, agent, inputs, 10, start="rest")
    print(f"rule_train learner={args.learner} fidelity={args.fidelity} seed={args.seed} "
          f"kept_at={chosen['chosen_at_episode']} training_check={chosen['validation_solved']}/10 "
          f"reporting_{verdict.summary()} random_{random.summary()} rest_{rest.summary()} "
          f"wall_s={time.perf_counter() - started:.0f}")


if __name__ == "__main__":
    import os
    import runpy  # the header line every benchmark prints first (benchmarks/provenance.py)

    runpy.run_path(os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "provenance.py"),
                   run_name="__main__")
    main()
