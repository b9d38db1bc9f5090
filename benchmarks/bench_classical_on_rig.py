"""The classical swing-ups run from the laptop on a virtual rig over MQTT, judged by the kit's rule
(`pendkit eval --controller NAME --backend rig`: ten episodes from rest), behind each network impairment.

    python benchmarks/bench_classical_on_rig.py [--controllers energy trajopt] [--impairments none classroom-wifi]
"""

from __future__ import annotations

import argparse
import time

from click.testing import CliRunner

from pendkit.cli import main as pendkit_main
from pendkit.link.virtual_rig import LocalRig
from pendkit.network import IMPAIRMENTS


def judged_on_a_virtual_rig(controller: str, impairment: str, episodes: int) -> tuple[str, str, float]:
    """(the rule's verdict line, the summary line, wall seconds) of one `pendkit eval --controller` run."""
    rig = LocalRig(impairment=impairment)
    started = time.perf_counter()
    try:
        result = CliRunner().invoke(pendkit_main, ["eval", "--controller", controller, "--backend", "rig", "--broker",
                                                   rig.url, "--rig", rig.rig, "--episodes", str(episodes)])
    finally:
        rig.stop()
    lines = result.output.splitlines()
    verdict = next((line for line in lines if line.startswith("controller: ")), result.output.strip()[-120:])
    return verdict.removeprefix("controller: "), lines[-1] if lines else "", time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--controllers", nargs="+", default=["energy", "trajopt"])
    parser.add_argument("--impairments", nargs="+", default=["none", "classroom-wifi"], choices=list(IMPAIRMENTS))
    parser.add_argument("--episodes", type=int, default=10)
    args = parser.parse_args()
    print("| controller | impairment | verdict | solved, median time to upright | wall time |")
    print("|---|---|---|---|---|")
    for controller in args.controllers:
        for impairment in args.impairments:
            verdict, summary, wall_s = judged_on_a_virtual_rig(controller, impairment, args.episodes)
            print(f"| {controller} | {impairment} | {verdict} | {summary} | {wall_s:.0f} s |", flush=True)


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py (here: tests load this file alone)

    print_header()
    main()
