"""Learning and designs that carry to rigs they were not built for: the evidence for issue 23.

    python benchmarks/bench_transfer.py zero-shot [--starts 5]        # each controller x presets and random rigs
    python benchmarks/bench_transfer.py zero-shot --policy r-td3-bank-robust --network none  # one policy, no network
    python benchmarks/bench_transfer.py ceiling [--starts 5]          # the classical designs as oracles
    python benchmarks/bench_transfer.py adapt [--rigs 6] [--seeds 0 1 2] [--jobs 2] [--policy r-dqn-robust]
                                              [--loop-episodes 3]
    python benchmarks/bench_transfer.py ablations [--rigs 6] [--jobs 2]
    python benchmarks/bench_transfer.py device [--rigs 6]             # device designs on true parameters
    python benchmarks/bench_transfer.py device-policy [--policy r-td3-bank-robust]  # a policy run on each device

zero-shot: the shipped policies and the classical controllers (energy swing-up + LQR, minimum-time swing-up),
all designed or trained without the rig, on the five servo presets and the 10 held-out rigs
(`pendkit.agents.rig_suite`, seed 2026), one episode from rest and `--starts` random starts each;
`--policy` judges that shipped policy alone, `--network none` takes every rig's network away (what a
policy run on the rig's device would meet, before any port to the firmware).

ceiling: the same rigs, the classical controllers designed on each rig's true parameters and acting on the
twin's true state, with the rig's network and without one: what the kit's model-based control reaches
when it knows everything (a bound to read the robust policy's goal against).

adapt: `pendkit adapt` on `--rigs` hidden rigs drawn from the held-out ranges with seed 2027 (another draw
than zero-shot's, written as RigParams files beside the results; the network and calibration error stay
with the rig): rig time used, wall time, the identified servo speed and natural frequency against the
rig's own (the servo's damping ratio as identified/true), and greedy episodes solved on the rig by the
adapted policy and both classical controllers; `--policy` the shipped policy adaptation starts from
(default: `pendkit adapt`'s).

ablations, one factor at a time on the same rigs: randomisation only (the starting policy as shipped);
identification only (train on the identified twin, no rig fine-tuning); identification + fine-tuning (the
whole of `pendkit adapt`); and `dqn+estimated` trained afresh on the identified twin instead of R-DQN.
Every line ends `solved=K/N median_upright_s=X`.

device: both classical designs for the rig's own device, made on each rig's true parameters and run there
from rest (3 episodes, the rig's network and calibration error): the five presets, 12 validation rigs
(training ranges, seed 77) and the `--rigs` hidden rigs; what the device's estimate and law reach when
identification is perfect.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from pendkit.sweep.ray_runner import map_on_ray

ADAPT_RIG_SEED = 2027
EVALUATION_EPISODES = 3


def zero_shot(starts: int, only: str | None = None, network: str = "rig") -> None:
    from pendkit.adapt.routes import CLASSICAL, classical_on_env
    from pendkit.agents.pretrained import POLICIES, policy_weights
    from pendkit.agents.rig_suite import policy_on_rigs, preset_rigs, random_rigs, rig_env
    from pendkit.agents.runs import Evaluation
    from pendkit.errors import ConfigError
    from pendkit.rig import RigParams
    from pendkit.sim.randomize import RandomRig

    rigs = {name: rig if network == "rig" else without_network(rig)
            for name, rig in {**preset_rigs(), **random_rigs()}.items()}
    suffix = "" if network == "rig" else "-network-none"
    starts_list = ["rest"] + ["random"] * starts
    for name in [only] if only else POLICIES:
        try:
            spec, state = policy_weights(name)
        except ConfigError:
            print(f"zero-shot controller={name} missing (not built)")
            continue
        _report(name + suffix, policy_on_rigs(spec, state, rigs, starts))
    for controller in () if only else CLASSICAL:
        design = rig_env(RandomRig(RigParams(), None, 0), action_mode="continuous", filter_coefficient=0.0)
        outcomes = {}
        for rig_name, rig in rigs.items():
            env = rig_env(rig, action_mode="continuous", filter_coefficient=0.0)
            outcomes[rig_name] = sum((classical_on_env(design, env, controller, 1, 10_000 + k, start)
                                      for k, start in enumerate(starts_list)), Evaluation([], [], [], []))
            env.close()
        _report(controller + suffix, outcomes)


def policy_on_device(starts: int, policy: str, seed: int = 10_000) -> dict:
    """`policy` (a shipped name or a weights file) exported as its rig's device blob
    (`pendkit.deploy.learned_blob`: a bank policy keeps its bank, designed for the device's timing), uploaded to
    each preset's and held-out rig's device and run there from rest and `starts` random starts (seeds `seed`,
    `seed + 1`, ..., the laptop's episodes' by default): no network between the readings and the targets;
    heartbeats still cross the rig's own. Returns each rig's `Evaluation`."""
    from pendkit.agents.pretrained import policy_weights
    from pendkit.agents.rig_suite import preset_rigs, random_rigs
    from pendkit.agents.runs import load_weights
    from pendkit.deploy.learned_blob import learned_policy_blob
    from pendkit.deploy.on_twin import blob_on_rigs
    from pendkit.device.controller_blob import pack

    spec, state = load_weights(policy) if policy.endswith(".pt") else policy_weights(policy)
    blob = pack(learned_policy_blob(spec, state))
    outcomes = blob_on_rigs(blob, {**preset_rigs(), **random_rigs()}, starts, seed, say=lambda name, outcome: print(
        f"device-policy controller={policy} rig={name} {outcome.summary()}", flush=True))
    _report(policy, outcomes, mode="device-policy")
    return outcomes


def without_network(rig):
    """The same drawn rig with no network between it and the host (what running on its device removes)."""
    import dataclasses

    from pendkit.network import NetworkImpairment

    return dataclasses.replace(rig, network=NetworkImpairment())


def ceiling(starts: int, seed: int = 10_000, networks=("rig", "none"), controllers=None) -> dict:
    """The classical designs (`controllers`, default all) with everything the kit could know: each rig's true
    parameters, acting on the twin's true state (no estimate, no reading delay), with the rig's own network
    and with none, from rest and `starts` random starts (seeds `seed`, `seed + 1`, ...). What they cannot
    solve is beyond the kit's model-based control on the laptop, a bound for any policy's goal. Returns
    {(controller, network): each rig's `Evaluation`}."""
    import math

    from pendkit.adapt.routes import CLASSICAL
    from pendkit.agents.rig_suite import preset_rigs, random_rigs, rig_env
    from pendkit.agents.runs import Evaluation, judged_episode
    from pendkit.deploy.controllers import controller_named
    from pendkit.episode import UNTIL_DONE, run_episode

    def true_state(info):  # the twin's exact joint state, in place of what the host reads
        truth = info["true_state"]
        return info["state"]._replace(
            pendulum_angle_rad=truth["pendulum_angle_rad"] % (2 * math.pi),
            pendulum_velocity_rad_s=truth["pendulum_velocity_rad_s"], arm_angle_rad=truth["arm_angle_rad"],
            arm_velocity_rad_s=truth["arm_velocity_rad_s"], observation_age_s=0.0)

    def episode(env, policy, seed: int, start: str) -> Evaluation:
        seen = {"info": env.reset(seed=seed, options={"start": start})[1]}
        policy.reset(true_state(seen["info"]))
        angles = []

        def observe(action, observation, reward, terminated, truncated, info) -> None:
            seen["info"] = info
            angles.append(info["angle_from_upright_rad"])

        run_episode(env, lambda observation, state: policy(None, true_state(seen["info"])), steps=UNTIL_DONE,
                    started=(None, seen["info"]), on_step=observe)
        return judged_episode(angles, env.unwrapped.dt)

    rigs, found = {**preset_rigs(), **random_rigs()}, {}
    for network in networks:
        for controller in controllers or CLASSICAL:
            outcomes = {}
            for rig_name, rig in rigs.items():
                rig = rig if network == "rig" else without_network(rig)
                env = rig_env(rig, action_mode="continuous", filter_coefficient=0.0)
                design = rig_env(rig, action_mode="continuous", filter_coefficient=0.0)
                policy = controller_named(controller).host(design)
                outcomes[rig_name] = sum((episode(env, policy, seed + k, start) for k, start in
                                          enumerate(["rest"] + ["random"] * starts)), Evaluation([], [], [], []))
                env.close()
                design.close()
            _report(f"{controller}-oracle-network-{network}", outcomes, "ceiling")
            found[controller, network] = outcomes
    return found


def _report(controller: str, outcomes: dict, mode: str = "zero-shot") -> None:
    from pendkit.agents.rig_suite import summary

    for rig_name, outcome in outcomes.items():
        print(f"{mode} controller={controller} rig={rig_name} {outcome.summary()}", flush=True)
    for group in ("presets", "random"):
        chosen = {k: v for k, v in outcomes.items() if k.startswith("random") == (group == "random")}
        total = summary(chosen)
        held = total["min_held_fraction"]
        print(f"{mode} controller={controller} rigs={group} solved={total['solved']}/{total['episodes']} "
              f"share={total['solved_share']:.2f} median_upright_s={_shown(total['median_upright_s'])} "
              f"min_held_fraction={_shown(held)}", flush=True)


def _shown(value) -> str:
    return "-" if value is None else f"{value:.2f}"


def adapt_rigs(count: int):
    from pendkit.sim.randomize import held_out_rigs

    return [(f"hidden-{k:02d}", rig) for k, rig in enumerate(held_out_rigs(count, ADAPT_RIG_SEED))]


def adapt_one(rig_name: str, rig, seed: int, variant: str, out_root: str, policy: str | None = None,
              loop_episodes: int | None = None, candidates: tuple[str, ...] = ()) -> str:
    """One adaptation of one rig; `variant` is "default" (`pendkit adapt` as shipped), "full" (one policy, the
    10-episode budget, a fixed-latency twin: the route as first measured), "identification-only",
    "no-training" (identified, the policy's weights as shipped: a bank-trained policy's bank joined by the
    identified rig) or a learner
    trained afresh until the rule holds on the identified twin (at most 300 episodes; "LEARNER@excitation":
    with the excitation's rig time alone, no fine-tuning on the rig), or "chosen" (the excitation alone; the
    policy and each of `candidates`, as shipped and trained on the twin, judged there; the best to the rig;
    "chosen-full": the same, then fine-tuned on the rig in the rest of the budget);
    `policy`: the shipped policy the first two start from (default: AdaptConfig's); `loop_episodes`: the
    excitation's episodes of small steps (default: AdaptConfig's). A variant ending in "+network" runs the
    identified twin behind the network the excitation logs show (`AdaptConfig.measured_network`)."""
    import torch

    torch.set_num_threads(1)
    from pendkit.adapt.rigs import twin_rig
    from pendkit.adapt.session import AdaptConfig, adapt

    out = Path(out_root) / f"{rig_name}-{variant}-s{seed}"
    out.mkdir(parents=True, exist_ok=True)
    rig.params.save(out / "hidden-rig.json")
    chosen = {"policy": policy} if policy else {}
    if loop_episodes is not None:
        chosen["loop_episodes"] = loop_episodes
    # the variants as first measured: one starting policy, the full 10-episode budget fine-tuned, a fixed-latency
    # twin; "excitation only" was a 6-episode budget: the excitation (1.3 episodes) and 4 of fine-tuning
    start = {"episodes": 10, "candidates": (), "fine_tune": True, **chosen}
    excitation_only = {**start, "episodes": AdaptConfig().excitation_episodes}
    changes = {"full": start, "identification-only": excitation_only,
               "no-training": {**excitation_only, "twin_episodes": 0},
               "chosen": {**excitation_only, "candidates": tuple(candidates)},
               "chosen-full": {**start, "candidates": tuple(candidates)}}
    base, measured = variant.removesuffix("+network"), variant.endswith("+network")  # the twin behind the logs' network
    learner_name, _, budget = base.partition("@")  # "LEARNER@excitation": afresh, no fine-tuning on the rig
    afresh = {**(excitation_only if budget == "excitation" else start), "twin_episodes": 300, "policy": learner_name}
    if base == "default":  # pendkit adapt as it is shipped, --policy aside
        config = AdaptConfig(seed=seed, evaluation_episodes=EVALUATION_EPISODES, **chosen)
    else:
        config = AdaptConfig(seed=seed, evaluation_episodes=EVALUATION_EPISODES, measured_network=measured,
                             **changes.get(base, afresh))
    report = adapt(twin_rig(rig.params, rig.network, rig.residual_offset_counts), out, config, say=lambda _: None)
    found, true = report["identified"], rig.params
    speed = found["servo_speed_s_per_60deg"] / true.servo_speed_s_per_60deg - 1
    omega = found["pendulum_natural_frequency_rad_s"] / true.pendulum_natural_frequency_rad_s - 1
    episode_s = 500 * true.control_step_ms / 1000
    classical, device = report["classical_on_rig"], report["classical_on_device"]
    return (f"adapt rig={rig_name} variant={variant} from={config.policy} seed={seed} "
            f"rig_s={report['rig_s_adaptation']:.0f} "
            f"rig_episodes={report['rig_s_adaptation'] / episode_s:.1f} wall_s={report['wall_s_adaptation']:.0f} "
            f"speed_error={speed:+.0%} omega_error={omega:+.0%} "
            f"servo_damping={found['servo_damping_ratio']:.2f}/{true.servo_damping_ratio:.2f} "
            f"loop_error_deg={found['servo_full_torque_error_deg']:.2f}/{true.servo_full_torque_error_deg:.2f} "
            f"energy={classical['energy']['summary']} "
            f"trajopt={classical['trajopt']['summary']} device_energy={device['energy']['summary']} "
            f"device_trajopt={device['trajopt']['summary']} device_tried={device.get('tried', {}).get('summary', '-')} "
            f"tried_design={_chosen(report)} on_twin={_on_twin(report)} "
            f"policy_device={report['policy_on_device']['summary'].replace(' ', '_')} "
            f"policy: {report['policy_on_rig']['summary']}")


def _on_twin(report: dict) -> str:
    rows = report.get("candidates_on_twin") or []
    return ",".join(f"{row['policy']}/{row['stage'].replace(' ', '-')}:{row['held']}"
                    f"{'' if row.get('held_on_device') is None else '/' + str(row['held_on_device'])}"
                    for row in rows) or "-"


def _chosen(report: dict) -> str:
    chosen = report.get("chosen_design")
    return f"{chosen['controller']}/{chosen['label'].replace(' ', '-')}" if chosen else "-"


def device_on_true_parameters(hidden: int) -> None:
    from pendkit.adapt.identify import Identification
    from pendkit.adapt.rigs import twin_rig
    from pendkit.adapt.routes import CLASSICAL, classical_on_device
    from pendkit.agents.rig_suite import preset_rigs, validation_rigs
    from pendkit.sim.fidelity import FIDELITY_PRESETS

    twin_network = FIDELITY_PRESETS["realistic"].network  # a preset's rig keeps the realistic twin's own
    groups = {"presets+validation": {**preset_rigs(), **validation_rigs(12)}, "hidden": dict(adapt_rigs(hidden))}
    for group, rigs in groups.items():
        totals = dict.fromkeys(CLASSICAL, 0)
        for name, rig in rigs.items():
            known = Identification(rig.params, 0.0, 0.0, 0.0, 0, 0.0)  # the truth, as if identified exactly
            outcome = classical_on_device(twin_rig(rig.params, rig.network or twin_network, rig.residual_offset_counts),
                                          known, EVALUATION_EPISODES)
            for controller in CLASSICAL:
                totals[controller] += sum(outcome[controller]["solved"])
            print(f"device rig={name} " + " ".join(f"{c}: {outcome[c]['summary']}" for c in CLASSICAL), flush=True)
        print(f"device group={group} rigs={len(rigs)} episodes_each={EVALUATION_EPISODES} "
              + " ".join(f"{c}_solved={totals[c]}/{EVALUATION_EPISODES * len(rigs)}" for c in CLASSICAL), flush=True)


def randomisation_only(rig_name: str, rig, policy: str | None = None) -> str:
    from pendkit.adapt.session import AdaptConfig
    from pendkit.agents.pretrained import policy_weights
    from pendkit.agents.rig_suite import policy_on_rigs

    name = policy or AdaptConfig().policy
    spec, state = policy_weights(name)
    outcome = policy_on_rigs(spec, state, {rig_name: rig}, starts=EVALUATION_EPISODES - 1)[rig_name]
    return f"adapt rig={rig_name} variant=randomisation-only ({name}) policy: {outcome.summary()}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mode", choices=["zero-shot", "ceiling", "adapt", "ablations", "device", "device-policy"])
    parser.add_argument("--starts", type=int, default=5)
    parser.add_argument("--start-seed", type=int, default=10_000,
                        help="ceiling, device-policy: the first episode's seed (the laptop's figures use 10 000)")
    parser.add_argument("--rigs", type=int, default=6)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    parser.add_argument("--jobs", type=int, default=None, help="CPUs of the local Ray (default: all)")
    parser.add_argument("--address", default=None, help="an existing Ray cluster (auto, or ray://HOST:10001)")
    parser.add_argument("--out", default=None, help="Where the adaptations write (default: a temporary folder).")
    parser.add_argument("--policy", default=None, help="The shipped policy adaptation starts from.")
    parser.add_argument("--variants", nargs="+", default=None,
                        help="adapt's variants to run (default: pendkit adapt's defaults; full, identification-only, "
                             "no-training, chosen, chosen-full, "
                             "randomisation-only, a learner afresh; +network: the twin behind the logs' network); "
                             "default by mode")
    parser.add_argument("--candidates", nargs="*", default=["r-td3-bank-robust"],
                        help="adapt's variant chosen: further shipped policies judged on the identified twin.")
    parser.add_argument("--network", choices=["rig", "none"], default="rig",
                        help="zero-shot: each rig's own network, or none (the conditions on the rig's device)")
    parser.add_argument("--only", nargs="+", default=None, help="adapt: only these of the hidden rigs (hidden-05 ...)")
    parser.add_argument("--loop-episodes", type=int, default=None,
                        help="Excitation episodes of small steps that show the servo's loop (default: adapt's).")
    args = parser.parse_args()
    if args.mode == "zero-shot":
        zero_shot(args.starts, args.policy, args.network)
        return
    if args.mode == "ceiling":
        ceiling(args.starts, args.start_seed)
        return
    if args.mode == "device":
        device_on_true_parameters(args.rigs)
        return
    if args.mode == "device-policy":
        policy_on_device(args.starts, args.policy or "r-td3-bank-robust", args.start_seed)
        return
    rigs = [(name, rig) for name, rig in adapt_rigs(args.rigs) if args.only is None or name in args.only]
    variants = args.variants or (["default"] if args.mode == "adapt"
                                 else ["identification-only", "full", "dqn+estimated"])
    out_root = args.out or tempfile.mkdtemp(prefix="bench-transfer-")
    if args.mode == "ablations" or "randomisation-only" in variants:
        for rig_name, rig in rigs:
            print(randomisation_only(rig_name, rig, args.policy), flush=True)
    work = [(name, rig, seed, variant, out_root, args.policy, args.loop_episodes, tuple(args.candidates))
            for variant in variants if variant != "randomisation-only" for seed in args.seeds for name, rig in rigs]
    for line in map_on_ray(adapt_one, work, args.address, args.jobs) if work else ():  # one CPU per rig
        print(line, flush=True)


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py (here: tests load this file alone)

    print_header()
    main()
