"""The servo refined over the loop episodes: is the loop read better, and does the device's plan hold more often?

    python benchmarks/bench_transfer.py adapt --rigs 6 --seeds 0 1 2 --loop-episodes 3 --out ROOT
    python benchmarks/bench_refinement.py ROOT [--episodes 6] [--jobs 2] [--skip hidden-02]

Each adaptation saved under ROOT (recorded with loop episodes) is identified again from its own recordings,
three ways, paired on the same recordings and the same hidden rig:
- `jumps`: the jump episodes only, three fits and the closest kept (what `pendkit adapt` does without loop
  episodes);
- `servo`: that fit, its servo refined over every recording (`refine_servo`, the loop episodes included);
- `servo+tip`: the same with the tip's mass refined as well, the free swing kept (stage 2 leaves the tip at the
  prior's: a heavy tip is otherwise read as a longer dowel and a softer loop).
The device's minimum-time plan made on each twin then runs `--episodes` times from rest on the hidden rig (its
network and calibration error, recalibrated as the adaptation did). Per line: the loop's full-torque error,
damping ratio and tip mass read against the truth, and `solved=K/N`.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_transfer import adapt_rigs  # noqa: E402

from pendkit.sweep.ray_runner import map_on_ray  # noqa: E402

VARIANTS = ("jumps", "servo", "servo+tip")


def refit(folder: str, hidden, episodes: int) -> list[str]:
    """The three identifications of one saved adaptation, each with its device plan run on `hidden`, its rig."""
    import torch

    torch.set_num_threads(1)
    from pendkit.adapt.excitation import Recording
    from pendkit.adapt.identify import REFINED, identify_best, refine_servo
    from pendkit.adapt.rigs import twin_rig
    from pendkit.adapt.routes import classical_on_device

    path = Path(folder)
    report = json.loads((path / "report.json").read_text())
    config = report["config"]
    rig_name = path.name.split("-full-")[0]
    recordings = [Recording.from_dict(r) for r in json.loads((path / "excitation.json").read_text())]
    jumps = recordings[:config["excitation_episodes"]]
    rig = twin_rig(hidden.params, hidden.network, hidden.residual_offset_counts)
    prior = rig.prior()
    fit = identify_best(jumps, prior, config["identification_evaluations"],
                        seeds=[config["seed"] + k for k in range(config["identification_restarts"])])
    fits = {"jumps": fit, "servo": refine_servo(fit, recordings, prior, config.get("refinement_evaluations", 300)),
            "servo+tip": refine_servo(fit, recordings, prior, 400, fields=REFINED + ("tip_mass_kg",))}
    shift = report.get("encoder_recalibrated_counts", 0)
    if shift:
        rig.recalibrate(shift)
    offset = (prior.encoder_offset_counts + shift) % prior.encoder_counts
    true, lines = hidden.params, []
    for variant, found in fits.items():
        found = dataclasses.replace(found, params=dataclasses.replace(found.params, encoder_offset_counts=offset))
        outcome = classical_on_device(rig, found, episodes)["trajopt"]
        p = found.params
        lines.append(f"refinement rig={rig_name} seed={config['seed']} variant={variant} cost={found.cost:.2e} "
                     f"loop_error_deg={p.servo_full_torque_error_deg:.2f}/{true.servo_full_torque_error_deg:.2f} "
                     f"servo_damping={p.servo_damping_ratio:.2f}/{true.servo_damping_ratio:.2f} "
                     f"tip_g={1000 * p.tip_mass_kg:.1f}/{1000 * true.tip_mass_kg:.1f} "
                     f"speed_error={p.servo_speed_s_per_60deg / true.servo_speed_s_per_60deg - 1:+.0%} "
                     f"device_trajopt={outcome['summary']}")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", type=Path, help="bench_transfer.py adapt's --out, run with --loop-episodes")
    parser.add_argument("--episodes", type=int, default=6)
    parser.add_argument("--jobs", type=int, default=None)
    parser.add_argument("--skip", nargs="*", default=[], help="rigs to leave out (e.g. one no design reaches)")
    args = parser.parse_args()
    folders = sorted(str(f) for f in args.root.glob("hidden-*-full-s*")
                     if f.name.split("-full-")[0] not in args.skip and (f / "report.json").exists())
    hidden = dict(adapt_rigs(6))
    totals = dict.fromkeys(VARIANTS, 0)
    calls = [(folder, hidden[Path(folder).name.split("-full-")[0]], args.episodes) for folder in folders]
    for lines in map_on_ray(refit, calls, None, args.jobs):
        for line in lines:
            print(line, flush=True)
            variant = line.split("variant=")[1].split()[0]
            totals[variant] += int(line.split("device_trajopt=solved=")[1].split("/")[0])
    print("refinement totals " + " ".join(f"{v}={totals[v]}/{args.episodes * len(folders)}" for v in VARIANTS))


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py (here: tests load this file alone)

    print_header()
    main()
