"""Every shipped policy on the twin it was trained for, and the classical controllers beside them: random
starts, starts hanging still, and (with --pushes) two pushes of a hand per episode (`pendkit.sim.pushes`).

One line per policy or controller and condition:

    policy=NAME rig=NAME solved=K/N rest=K/N held_min=F [pushes=SIZE]

solved: greedy episodes from the authors' random starts that hold the last 200 steps within 0.3 rad; rest:
the same from hanging still; held_min: of the solved episodes, the smallest share of the steps after the
pendulum was first caught (15 steps in a row within 0.3 rad) that stayed within it (1.0: it never fell out
once up; `pendkit.agents.runs.held_fraction`). Starts come from
the kit's reporting seeds (`pendkit.agents.policy_rule.REPORT_SEED`), never the ones training was judged
on. Goals (issue 43): a shipped policy >= 19/20 random, 10/10 rest, held_min >= 0.99 (the shipped bar,
`pendkit.agents.policy_rule.SHIPPED_TEXT`, that `pendkit policies list` judges each one by); under two `hand`
pushes >= 9/10 for the shipped continuous policy and the classical controllers.

    python benchmarks/bench_policies.py [--random 20] [--rest 10] [--pushes hand] [--policies NAME ...]
                                        [--controllers energy trajopt] [--record]

--record writes the figures to pendkit/data/policies/measured.json, which `pendkit policies list` prints.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import pendkit
from pendkit.agents.policy_rule import REPORT_SEED
from pendkit.agents.pretrained import (
    MEASURED_FILE,
    POLICIES,
    POLICY_DIR,
    measured_figures,
    policy_weights,
    weights_digest,
)
from pendkit.agents.runs import Evaluation, build_run, evaluate_agent, judge_runs, make_env
from pendkit.deploy.controllers import CONTROLLER_NAMES, controller_named
from pendkit.sim.pushes import PendulumPushes

REST_SEED = REPORT_SEED + 500  # apart from the random starts' seeds


def pushed(env, size: str | None, seed: int):
    return env if size is None else PendulumPushes(env, size, per_episode=2, seed=seed)


def policy_outcomes(name: str, starts: int, rest: int, pushes: str | None) -> tuple[str, Evaluation, Evaluation]:
    spec, state = policy_weights(name)
    env = pushed(make_env(spec), pushes, REPORT_SEED)
    _, agent, inputs = build_run(spec, env)
    agent.load_state_dict(state)
    random = evaluate_agent(env, agent, inputs, starts, REPORT_SEED, "random")
    hanging = evaluate_agent(env, agent, inputs, rest, REST_SEED, "rest")
    env.close()
    return spec.preset or spec.fidelity, random, hanging


def controller_outcomes(name: str, fidelity: str, starts: int, rest: int, pushes: str | None) -> tuple[Evaluation, ...]:
    outcomes = []
    for count, start, seed in ((starts, "random", REPORT_SEED), (rest, "rest", REST_SEED)):
        together = Evaluation([], [], [], [])
        for k in range(count):
            env = pushed(pendkit.make(action_mode="continuous", fidelity=fidelity, filter_coefficient=0.0), pushes,
                         seed + k)
            together += judge_runs(env, controller_named(name).host(env), [start], seed + k)
        outcomes.append(together)
    return tuple(outcomes)


def line(name: str, rig: str, random: Evaluation, hanging: Evaluation, pushes: str | None) -> tuple[str, dict]:
    both = random + hanging
    held = both.min_held_fraction
    figures = {"rig": rig, "solved": f"{sum(random.solved)}/{len(random.solved)}",
               "rest": f"{sum(hanging.solved)}/{len(hanging.solved)}",
               "held_min": None if held is None else round(held, 3)}
    text = (f"policy={name} rig={rig} solved={figures['solved']} rest={figures['rest']} "
            f"held_min={'-' if held is None else f'{held:.3f}'}" + (f" pushes={pushes}" if pushes else ""))
    return text, figures


def without_policies(argv: list[str]) -> list[str]:
    """`argv` without the choice of what to measure (`--policies NAME ...`, `--controllers NAME ...`)."""
    kept, skipping = [], False
    for arg in argv:
        if arg in ("--policies", "--controllers"):
            skipping = True
        elif skipping and not arg.startswith("--"):
            continue
        else:
            skipping = False
            kept.append(arg)
    return kept


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--random", type=int, default=20, help="episodes from random starts")
    parser.add_argument("--rest", type=int, default=10, help="episodes from hanging still")
    parser.add_argument("--pushes", default=None, help="also run every row with two pushes of this size (hand)")
    parser.add_argument("--policies", nargs="*", default=None, help="shipped policies (default: all)")
    parser.add_argument("--controllers", nargs="*", default=list(CONTROLLER_NAMES), choices=CONTROLLER_NAMES)
    parser.add_argument("--controller-fidelity", default="realistic")
    parser.add_argument("--record", action="store_true", help=f"write the figures to {MEASURED_FILE.name}")
    args = parser.parse_args()
    command = "python benchmarks/bench_policies.py " + " ".join(sys.argv[1:])
    # what measures every policy this way (the file's command, whichever policies this run measured)
    everything = "python benchmarks/bench_policies.py " + " ".join(without_policies(sys.argv[1:]))
    print(f"# {command}", flush=True)
    names = args.policies if args.policies is not None else [n for n in POLICIES if (POLICY_DIR / f"{n}.pt").exists()]
    recorded = {}
    for condition in [None] + ([args.pushes] if args.pushes else []):
        for name in names:
            started = time.perf_counter()
            rig, random, hanging = policy_outcomes(name, args.random, args.rest, condition)
            text, figures = line(name, rig, random, hanging, condition)
            print(f"{text} wall_s={time.perf_counter() - started:.0f}", flush=True)
            recorded.setdefault(name, {"weights_sha256": weights_digest(name)})[
                "pushes_" + condition if condition else "twin"] = figures
        for controller in args.controllers:
            random, hanging = controller_outcomes(controller, args.controller_fidelity, args.random, args.rest,
                                                  condition)
            print(line(controller, args.controller_fidelity, random, hanging, condition)[0], flush=True)
    if args.record:  # the other policies' figures stay while their weights are the ones measured
        kept, _ = measured_figures()
        kept = {name: figures for name, figures in kept.items() if name in POLICIES and name not in recorded
                and (POLICY_DIR / f"{name}.pt").exists() and figures.get("weights_sha256") == weights_digest(name)}
        MEASURED_FILE.write_text(json.dumps({"command": everything, "policies": {**kept, **recorded}}, indent=1)
                                 + "\n")
        print(f"recorded in {MEASURED_FILE}")


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py (here: tests load this file alone)

    print_header()
    main()
