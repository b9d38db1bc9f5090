"""Study: how much does the device goal's figure move with the random starts alone? The same policy blob and the
same minimum-time oracle (each rig known, its true state, no network) on the 5 presets and 10 held-out rigs,
rest + 5 random starts each, for several sets of starts (seeds 10 000.. are the ones every reported figure uses).

    python benchmarks/studies/start_sets.py [--policy r-td3-bank-robust] [--start-seeds 10000 20000 30000] \
        [--jobs 2]

One line per (what, start set), then each one's totals. Results: docs/results/robust.md.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))


def one_run(what: str, seed: int) -> tuple[str, int, dict[str, int]]:
    """(what, seed, episodes held on each rig); bench_transfer's own lines are not shown."""
    from benchmarks import bench_transfer
    from pendkit.agents.threads import use_kit_threads

    use_kit_threads()
    with contextlib.redirect_stdout(io.StringIO()):
        if what == "oracle":
            outcomes = bench_transfer.ceiling(5, seed, networks=("none",), controllers=("trajopt",))["trajopt", "none"]
        else:
            outcomes = bench_transfer.policy_on_device(5, what, seed)
    return what, seed, {rig: sum(outcome.solved) for rig, outcome in outcomes.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--policy", default="r-td3-bank-robust", help="a shipped policy or a weights file")
    parser.add_argument("--start-seeds", type=int, nargs="+", default=[10_000, 20_000, 30_000])
    parser.add_argument("--no-oracle", action="store_true")
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    whats = [args.policy] + ([] if args.no_oracle else ["oracle"])
    work = [(what, seed) for seed in args.start_seeds for what in whats]
    totals: dict[str, list[int]] = {what: [] for what in whats}
    by_rig: dict[str, dict[str, int]] = {what: {} for what in whats}
    with ProcessPoolExecutor(args.jobs) as pool:
        for what, seed, held in pool.map(one_run, *zip(*work)):
            presets = sum(n for rig, n in held.items() if not rig.startswith("random"))
            totals[what].append(sum(held.values()))
            for rig, n in held.items():
                by_rig[what][rig] = by_rig[what].get(rig, 0) + n
            print(f"start-sets what={what} seed={seed} presets={presets}/30 held_out={sum(held.values()) - presets}/60 "
                  f"all={sum(held.values())}/90", flush=True)
    for what, held in totals.items():
        print(f"start-sets what={what} sets={len(held)} all={held} min={min(held)} max={max(held)} "
              f"mean={sum(held) / len(held):.1f}", flush=True)
        print(f"start-sets what={what} per-rig (of {6 * len(held)}): "
              + " ".join(f"{rig}={n}" for rig, n in by_rig[what].items()), flush=True)


if __name__ == "__main__":
    import os
    import runpy  # the header line every benchmark prints first (benchmarks/provenance.py)

    runpy.run_path(os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "provenance.py"),
                   run_name="__main__")
    main()
