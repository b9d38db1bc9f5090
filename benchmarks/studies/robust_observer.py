"""Study: can TD3 reading the observer's estimate (td3+estimated, the kit's best learner on `realistic`) learn
one policy for every rig of the `robust` ranges, and what does the observer's knowledge of the rig do?

    python benchmarks/studies/robust_observer.py --observer nominal --seed 0    # the deployable setting
    python benchmarks/studies/robust_observer.py --observer told --seed 0       # the observer designed for
                                                                                 # each drawn rig (as adapt's
                                                                                 # identified one): td3-robust
    python benchmarks/studies/robust_observer.py --start-from td3-realistic     # fine-tuned over the ranges
    python benchmarks/studies/robust_observer.py --learner r-td3+both           # a GRU reading the estimate
                                                                                 # and the raw readings
    python benchmarks/studies/robust_observer.py --observer bank --observer-timing rig   # the bank designed for
                                                                                 # each drawn rig's delays
    python benchmarks/studies/robust_observer.py --start-from r-td3-bank-robust --learner r-td3+both
        --observer bank --observer-timing rig --network none --validate-on device   # (one command) fine-tuned
                                                                         # for the device's own loop, kept by
                                                                         # the device's verdict

Trains over `robust` (a new rig each episode), keeps the checkpoint that solves most validation rigs (8 rigs
from the training ranges, rest + one random start each), then prints the default rig (rest + 20 random
starts) and the 5 presets + 10 held-out rigs (rest + 5 random starts each, 90 episodes). About 25 minutes
of one core for 1000 episodes. Results: docs/results/robust.md.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import json
import time


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--observer", choices=["nominal", "told", "bank"], default="nominal",
                        help="what the observer is designed for in training and judging: the nominal rig, each "
                             "drawn rig, or a bank of candidate rigs (pendkit.sim.randomize.observer_bank)")
    parser.add_argument("--start-from", default=None, help="a shipped policy to fine-tune (default: afresh)")
    parser.add_argument("--learner", default="td3+estimated", help="a learner reading the observer's estimate")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--episodes", type=int, default=1000)
    parser.add_argument("--check-every", type=int, default=100)
    parser.add_argument("--agent", default="{}", help="agent settings as JSON, e.g. '{\"hidden\": [128, 128]}'; "
                        "robust: the shipped robust R-DQN's (pretrained.ROBUST_AGENT)")
    parser.add_argument("--observer-timing", choices=["trained", "rig"], default="trained",
                        help="the delays a pinned observer (nominal or bank) is designed for in training: the base "
                             "twin's, or each drawn rig's own (as each rig's evaluation and the device design them)")
    parser.add_argument("--network", choices=["robust", "none", "mixed"], default="robust",
                        help="the drawn rigs' networks in training: the robust ranges', none (the device's own "
                             "loop: readings and targets never cross a network), or mixed (each episode one of the "
                             "two, even odds)")
    parser.add_argument("--validate-on", choices=["laptop", "device"], default="laptop",
                        help="keep the checkpoint that holds most validation rigs from the laptop (8 rigs, rest + 1 "
                             "start) or as a blob on each rig's device (12 rigs, rest + 5 starts); with device, the "
                             "kept policy is also judged on the devices of the presets and held-out rigs")
    parser.add_argument("--fine-tune-lr", type=float, default=1.0, metavar="SCALE",
                        help="with --start-from: the actor's and critic's learning rates times SCALE (the saved "
                             "optimizers' rates come back with the weights, so they are scaled after loading)")
    parser.add_argument("--out", default=None, help="write the kept weights here (the kit's weights format)")
    parser.add_argument("--default-in-validation", type=int, default=0, metavar="STARTS",
                        help="also score each checkpoint on the default rig (rest + STARTS random starts) and "
                             "keep by the sum; each checkpoint's two scores are printed")
    args = parser.parse_args()
    from pendkit.agents.pretrained import (
        ROBUST_AGENT,
        PretrainedSpec,
        policy_weights,
        train_keeping_best,
        validation_and_default_score,
        validation_score,
    )
    from pendkit.agents.rig_suite import policy_on_rigs, preset_rigs, random_rigs, summary
    from pendkit.agents.runs import RunSpec, build_run
    from pendkit.agents.threads import use_kit_threads
    from pendkit.deploy.on_twin import policy_on_devices
    from pendkit.rig import RigParams
    from pendkit.sim.randomize import RandomRig

    use_kit_threads()
    told = args.observer == "told"
    agent = ROBUST_AGENT if args.agent == "robust" else json.loads(args.agent)
    observer = {"told": "rig", "bank": "bank"}.get(args.observer, "base")
    spec = PretrainedSpec(RunSpec(args.learner, "realistic", seed=args.seed, randomize="robust",
                                  observer=observer, agent=agent), args.episodes,
                          check_every=args.check_every)
    started = time.monotonic()
    env, agent, inputs = build_run(spec.run)
    if args.observer_timing == "rig" and not told:
        env.unwrapped.pin_observer(keep_timing=False)  # the same rigs (nominal or bank), each drawn rig's delays
    if args.start_from:
        agent.load_state_dict(policy_weights(args.start_from)[1])
        for optimizer in (agent.actor_optimizer, agent.critic_optimizer):
            for group in optimizer.param_groups:
                group["lr"] *= args.fine_tune_lr
    score = validation_score
    if args.default_in_validation:
        score = functools.partial(validation_and_default_score, starts=args.default_in_validation)
    if args.network == "none":
        without_network(env)
    if args.network == "mixed":
        half_without_network(env, args.seed)
    if args.validate_on == "device":
        score = device_validation_score
    _, chosen = train_keeping_best(env, agent, inputs, spec, score)
    state, run = agent.state_dict(), dataclasses.replace(spec.run, randomize="")
    if args.out:
        from pendkit.agents.runs import save_weights

        save_weights(args.out, agent, run, {**chosen, "episodes": args.episodes, "trained_on": "robust"})
    default = summary(policy_on_rigs(run, state, {"default": RandomRig(RigParams(), None, 0)}, starts=20))
    rigs = policy_on_rigs(run, state, {**preset_rigs(), **random_rigs(10)}, starts=5, observer_knows_rig=told)
    together = summary(rigs)
    if told:  # the same policy as it would run zero-shot: the observer bank, then the nominal rig's observer
        rigs_again = {**preset_rigs(), **random_rigs(10)}
        bank = summary(policy_on_rigs(run, state, rigs_again, starts=5))
        nominal = summary(policy_on_rigs(run, state, rigs_again, starts=5,
                                         wrap=lambda env: pin_nominal_observer(env)))
        print(f"zero-shot with the observer bank: {bank['solved']}/{bank['episodes']}, with the nominal rig's "
              f"observer: {nominal['solved']}/{nominal['episodes']}")
    if args.validate_on == "device":
        device = policy_on_devices(run, state, {**preset_rigs(), **random_rigs(10)})
        print("device " + " ".join(f"{name}={sum(e.solved)}/{len(e.solved)}" for name, e in device.items())
              + f" presets_and_held_out={summary(device)['solved']}/{summary(device)['episodes']}")
    extra = args.default_in_validation + 1 if args.default_in_validation else 0
    checked = 72 if args.validate_on == "device" else 16 + extra
    print(f"robust-observer learner={args.learner} observer={args.observer} timing={args.observer_timing} "
          f"from={args.start_from or 'afresh'} fine_tune_lr={args.fine_tune_lr} network={args.network} "
          f"validate_on={args.validate_on} "
          f"seed={args.seed} "
          f"episodes={args.episodes} chosen_at={chosen['chosen_at_episode']} "
          f"validation={chosen['validation_solved']}/{checked} default={default['solved']}/{default['episodes']} "
          f"presets_and_held_out={together['solved']}/{together['episodes']} "
          + " ".join(f"{name}={sum(e.solved)}/{len(e.solved)}" for name, e in rigs.items())
          + f" wall_s={time.monotonic() - started:.0f}")


def randomization(env):
    import gymnasium as gym

    from pendkit.sim.randomize import DomainRandomization

    while not isinstance(env, DomainRandomization):
        if not isinstance(env, gym.Wrapper):
            raise SystemExit("--network none or mixed needs a run over drawn rigs")
        env = env.env
    return env


def no_network(ranges):
    none = (0.0, 0.0)
    return dataclasses.replace(ranges, latency_floor_ms=none, latency_median_ms=none, latency_spread=none,
                               loss_pct=none)


def without_network(env) -> None:
    """Every rig `env`'s randomisation draws from now on has no network (no latency, nothing lost)."""
    drawing = randomization(env)
    drawing.ranges = no_network(drawing.ranges)


def half_without_network(env, seed: int) -> None:
    """Each rig `env`'s randomisation draws from now on has no network or the ranges' own, even odds (a coin of
    its own, so the rigs drawn are those of the same seed with either network)."""
    import numpy as np

    drawing = randomization(env)
    ranges, coin, reset = drawing.ranges, np.random.default_rng([seed, 7]), drawing.reset

    def reset_with_either(**kwargs):
        drawing.ranges = no_network(ranges) if coin.random() < 0.5 else ranges
        return reset(**kwargs)

    drawing.reset = reset_with_either


def device_validation_score(spec, state: dict) -> tuple[int, float]:
    """(episodes held, mean held fraction) of the policy's blob on 12 validation rigs' devices."""
    from pendkit.agents.rig_suite import summary, validation_rigs
    from pendkit.deploy.on_twin import policy_on_devices

    outcomes = policy_on_devices(spec.run, state, validation_rigs(12))
    held = [f or 0.0 for e in outcomes.values() for f in e.held_fractions]
    print(f"  device validation {summary(outcomes)['solved']}/{len(held)}")
    return summary(outcomes)["solved"], sum(held) / len(held)


def pin_nominal_observer(env):
    from pendkit.rig import RigParams

    env.unwrapped.pin_observer(RigParams())
    return env


if __name__ == "__main__":
    import os
    import runpy  # the header line every benchmark prints first (benchmarks/provenance.py)

    runpy.run_path(os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "provenance.py"),
                   run_name="__main__")
    main()
