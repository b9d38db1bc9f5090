"""`pendkit adapt` on the kit's hidden-rig stand-ins, each a virtual rig in its own process behind Mosquitto (its
parameters, network and encoder mounting only there): rig time, laptop time until every route is ready, how
far identification landed, the route it recommends and what that route solved on the rig.

    python benchmarks/bench_adapt.py [--rigs 6] [--evaluate 3] [--budget-s 300] [--backend mqtt|sim] [--quick]

The stand-ins are `bench_transfer.py adapt`'s (held-out ranges, seed 2027). `--backend sim` runs each as a
twin in this process instead (no broker: quicker, the same rigs). One line per rig:

    adapt rig=NAME rig_s=F laptop_s=F identified_err=F route=classical|learned solved=K/N

`laptop_s`: the wall time from the start until every route is ready (`--budget-s` caps it); `rig_s` the rig's own
count of its time before the evaluation; `identified_err` the larger relative error of the servo's speed and the
pendulum's natural frequency; `solved` the recommended route's greedy episodes on the rig (`--evaluate` of them;
the rig's evaluation of every route comes after `laptop_s`, in its own time: 6 routes x 30 s an episode).
"""

from __future__ import annotations

import argparse
import contextlib
import multiprocessing
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

ADAPT_RIG_SEED = 2027  # bench_transfer.py's hidden rigs


def serve_rig(broker_url: str, rig_id: str, hidden, stop) -> None:
    """A virtual rig of `hidden` (a RandomRig) until `stop` is set: its own process, as a rig is its own device."""
    from pendkit.link.virtual_rig import VirtualRig, VirtualRigGroup

    params = hidden.params
    mount = (params.encoder_offset_counts + hidden.residual_offset_counts) % params.encoder_counts
    rig = VirtualRig(rig_id, broker_url, params=params, impairment=hidden.network or "classroom-wifi",
                     mount_offset_counts=mount)
    group = VirtualRigGroup([rig], 1.0).start()
    stop.wait()
    group.stop()


@contextlib.contextmanager
def virtual_rig(broker_url: str, rig_id: str, hidden):
    context = multiprocessing.get_context("spawn")
    stop = context.Event()
    process = context.Process(target=serve_rig, args=(broker_url, rig_id, hidden, stop), daemon=True)
    process.start()
    try:
        time.sleep(3.0)  # connected and its status published
        yield
    finally:
        stop.set()
        process.join(timeout=15)


def adapt_line(name: str, hidden, report: dict) -> str:
    found, true = report["identified"], hidden.params
    speed = found["servo_speed_s_per_60deg"] / true.servo_speed_s_per_60deg - 1
    omega = found["pendulum_natural_frequency_rad_s"] / true.pendulum_natural_frequency_rad_s - 1
    route = report["recommended"]
    from pendkit.adapt.report_text import ROUTES

    if route is None:
        kind, solved = "none", f"0/{report['config']['evaluation_episodes']}"
    else:
        section, controller = ROUTES[route]
        result = report[section] if controller is None else report[section][controller]
        kind = "learned" if section.startswith("policy") else "classical"
        solved = f"{sum(result['solved'])}/{len(result['solved'])}"
    return (f"adapt rig={name} rig_s={report['rig_s_adaptation']:.1f} laptop_s={report['wall_s_adaptation']:.0f} "
            f"identified_err={max(abs(speed), abs(omega)):.3f} route={kind} solved={solved} "
            f"excitation_episodes={report['excitation_episodes']} identify_s={report['laptop_s_identification']:.0f} "
            f"speed_pinned={report['excitation_spread']['servo_speed_s_per_60deg']:.2f} "
            f"speed_error={speed:+.1%} omega_error={omega:+.1%} recommended=\"{route or '-'}\" "
            f"routes={every_route(report)} cut=\"{'; '.join(report.get('budget_cut') or []) or '-'}\"")


def every_route(report: dict) -> str:
    """Each route's greedy episodes solved on the rig: policy laptop/device, then each controller laptop/device."""
    def solved(result: dict) -> str:
        return f"{sum(result['solved'])}/{len(result['solved'])}" if "solved" in result else "-"

    policy = f"policy:{solved(report['policy_on_rig'])}/{solved(report['policy_on_device'])}"
    classical = [f"{name}:{solved(report['classical_on_rig'][name])}/{solved(report['classical_on_device'][name])}"
                 for name in report["classical_on_rig"]]
    return ",".join([policy, *classical])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rigs", type=int, default=6)
    parser.add_argument("--only", type=int, nargs="*", default=None, help="these stand-ins (0-based) only")
    parser.add_argument("--evaluate", type=int, default=3)
    parser.add_argument("--budget-s", type=float, default=300.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--backend", choices=("mqtt", "sim"), default="mqtt")
    parser.add_argument("--quick", action="store_true",
                        help="a smoke run: one search of 400 candidates, the shipped policy untrained, no candidates")
    args = parser.parse_args()

    from pendkit.adapt.rigs import mqtt_rig, twin_rig
    from pendkit.adapt.session import AdaptConfig, adapt
    from pendkit.link.broker import MosquittoBroker
    from pendkit.sim.randomize import held_out_rigs

    quick = {"identification_evaluations": 400, "identification_restarts": 1, "candidates": (), "twin_episodes": 0}
    config = AdaptConfig(evaluation_episodes=args.evaluate, budget_s=args.budget_s, seed=args.seed,
                         **(quick if args.quick else {}))
    for k, hidden in enumerate(held_out_rigs(args.rigs, ADAPT_RIG_SEED)):
        if args.only is not None and k not in args.only:
            continue
        name = f"hidden-{k:02d}"
        with tempfile.TemporaryDirectory() as work:
            if args.backend == "sim":
                rig = twin_rig(hidden.params, hidden.network, hidden.residual_offset_counts)
                report = adapt(rig, Path(work) / "out", config, say=lambda _: None)
            else:
                with MosquittoBroker(work) as broker, virtual_rig(broker.url, "r01", hidden):
                    report = adapt(mqtt_rig("r01", broker.url), Path(work) / "out", config, say=lambda _: None)
        print(adapt_line(name, hidden, report), flush=True)


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py (here: tests load this file alone)

    print_header()
    main()
