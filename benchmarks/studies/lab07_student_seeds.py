"""Lab 07's training cell as a student runs it, over seeds: the kit's DQN driven by numpy pieces written as
the lab asks (`pendkit.labs.agent_parts`, the same path as the notebook), trained until the kit's rule
passes (at most 150 episodes, a check every 10), then judged on the rule's reporting starts. One line a seed:

    python benchmarks/studies/lab07_student_seeds.py --seeds 0 1 2 3 4

Results: docs/results/labs.md (lab 07's claim). `--export WEIGHTS` writes the Q-network of a sweep trial's
weights.pt (`pendkit sweep run benchmarks/sweeps/lab07-fixed.yaml --out runs/lab07-fixed --seeds 4`, then
`--export runs/lab07-fixed/trials/dqn--ideal--seed4/weights.pt`) to the file lab 07 judges as its fixed-budget
policy (`pendkit.labs.agent_parts.fixed_budget_policy`).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import pendkit
from pendkit.agents.inputs import StepInputs
from pendkit.agents.policy_rule import REPORT_SEED, judge_policy
from pendkit.labs.agent_parts import StudentParts, train_until_rule


def epsilon(step, start, end, decay_steps):
    return start + min(1.0, step / decay_steps) * (end - start)


def td_target(rewards, dones, next_q_online, next_q_target, gamma, double):
    rows = np.arange(len(rewards))
    future = next_q_target[rows, next_q_online.argmax(axis=1)] if double else next_q_target.max(axis=1)
    return rewards + gamma * (1 - dones) * future


def huber(errors, delta):
    errors = np.abs(errors)
    return np.where(errors <= delta, 0.5 * errors**2, delta * (errors - 0.5 * delta))


def one_seed(seed: int, most: int) -> str:
    env = pendkit.make(fidelity="ideal", max_episode_steps=500)
    started = time.perf_counter()
    agent, returns, solved_at = train_until_rule(env, StudentParts(epsilon, td_target, huber), most, seed,
                                                 report=lambda line: None)
    held_out = judge_policy(env, agent, StepInputs.for_env(env), REPORT_SEED)
    return (f"seed={seed} episodes_to_rule={solved_at or '-'} episodes={len(returns)} "
            f"held_out={held_out.held}/10 ({held_out.held_by_start()}) first_held={held_out.evaluation.solved[0]} "
            f"returns={min(held_out.evaluation.returns):.0f}..{max(held_out.evaluation.returns):.0f} "
            f"wall_s={time.perf_counter() - started:.0f}")


def export(weights: str) -> None:
    import base64
    import json

    from pendkit.agents.runs import load_weights
    from pendkit.labs.agent_parts import FIXED_BUDGET_POLICY

    spec, state = load_weights(weights)
    q = {name: {"shape": list(t.shape), "float32": base64.b64encode(t.numpy().astype(np.float32).tobytes()).decode()}
         for name, t in state["q"].items()}
    record = {"what": "lab 07: the kit's DQN on the ideal twin after a fixed 80 episodes (lab07-fixed.yaml)",
              "seed": spec.seed, "q": q}
    FIXED_BUDGET_POLICY.write_text(json.dumps(record, indent=1) + "\n")
    print(f"wrote {FIXED_BUDGET_POLICY}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    parser.add_argument("--episodes", type=int, default=150)
    parser.add_argument("--export", metavar="WEIGHTS", help="write lab 07's fixed-budget policy from a weights.pt")
    args = parser.parse_args()
    if args.export:
        export(args.export)
        return
    for seed in args.seeds:
        print(one_seed(seed, args.episodes), flush=True)


if __name__ == "__main__":
    main()
