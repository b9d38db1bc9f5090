"""r-dqn-robust's recipe with one factor changed, a curriculum over the randomisation ranges (docs/rl.md:
the result was negative, so the kit does not ship it). Every range is shrunk towards the default rig by a
factor that grows 0.25, 0.5, 0.75 every 250 episodes, then 1; validation and the kept checkpoint as
`python -m pendkit.agents.pretrained r-dqn-robust`. Prints a line per check, then the kept checkpoint's
greedy episodes (rest + `--starts` random starts) on the presets and the held-out rigs.

    python benchmarks/bench_curriculum.py --seed 0 --out runs/curriculum-s0.pt   # long-running: ~25 min
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import time

from pendkit.agents.pretrained import POLICIES, validation_score
from pendkit.agents.rig_suite import policy_on_rigs, preset_rigs, random_rigs, summary
from pendkit.agents.runs import build_run, save_weights
from pendkit.agents.train import train_sync
from pendkit.rig import RigParams
from pendkit.sim.randomize import SERVO_FIELDS, TRAINING_RANGES, DomainRandomization, RigRanges

STAGE_EPISODES = 250


def default_point() -> dict[str, float]:
    """Each range's value on the default rig (the network and calibration error: none)."""
    d = RigParams()
    return {**{name: getattr(d, name) for name in SERVO_FIELDS},
            "mass_scale": 1.0, "tip_mass_scale": 1.0, "dowel_length_m": d.dowel_length_m,
            "pendulum_damping_scale": 1.0, "servo_min_counts": d.servo_min_counts,
            "servo_max_counts": d.servo_max_counts, "residual_offset_counts": 0.0, "latency_floor_ms": 0.0,
            "latency_median_ms": 0.0, "latency_spread": 0.0, "loss_pct": 0.0}


def ranges_at(share: float) -> RigRanges:
    """The training ranges shrunk towards the default rig to `share` of their reach on either side."""
    point, changes = default_point(), {}
    for field in dataclasses.fields(RigRanges):
        low, high = getattr(TRAINING_RANGES, field.name)
        centre = min(max(point[field.name], low), high)
        changes[field.name] = (centre + share * (low - centre), centre + share * (high - centre))
    return RigRanges(**changes)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", required=True, help="where the kept checkpoint is written (.pt)")
    parser.add_argument("--starts", type=int, default=5)
    args = parser.parse_args()
    spec = POLICIES["r-dqn-robust"]
    spec = dataclasses.replace(spec, run=dataclasses.replace(spec.run, seed=args.seed))
    env, agent, inputs = build_run(spec.run)
    randomizer = env
    while not isinstance(randomizer, DomainRandomization):
        randomizer = randomizer.env
    buffer = agent.new_buffer(spec.run.seed)
    returns, best, started = [], None, time.perf_counter()
    while len(returns) < spec.episodes:
        share = min(1.0, 0.25 * (1 + len(returns) // STAGE_EPISODES))
        randomizer.ranges = ranges_at(share)
        returns += train_sync(env, agent, spec.check_every, inputs, buffer=buffer,
                              seed=spec.run.seed * 7919 + len(returns))
        checked = validation_score(spec, agent.state_dict())
        print(f"episodes={len(returns)} share={share} validation_solved={checked[0]} "
              f"validation_return={checked[1]:.0f} train_return={sum(returns[-125:]) / 125:.0f} "
              f"wall_s={time.perf_counter() - started:.0f}", flush=True)
        if best is None or checked > best[0]:
            best = (checked, len(returns), copy.deepcopy(agent.state_dict()))
    agent.load_state_dict(best[2])
    run = dataclasses.replace(spec.run, randomize="")
    save_weights(args.out, agent, run, {"chosen_at_episode": best[1], "validation_solved": best[0][0]})
    for group, rigs in (("presets", preset_rigs()), ("held-out", random_rigs())):
        outcome = summary(policy_on_rigs(run, agent.state_dict(), rigs, args.starts))
        print(f"curriculum seed={args.seed} kept={best[1]} rigs={group} solved={outcome['solved']}/"
              f"{outcome['episodes']}", flush=True)


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py (here: tests load this file alone)

    print_header()
    main()
