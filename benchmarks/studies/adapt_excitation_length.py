"""Study: does the shorter excitation cost hidden-00 its routes? `pendkit adapt` on the first hidden-rig
stand-in with at least MIN excitation episodes, every identification search run (no budget) and the shipped
policy untrained (no candidates): only the excitation's length changes between runs.

    python benchmarks/studies/adapt_excitation_length.py MIN SEED    # e.g. 3 0, then 6 0
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))


def main() -> None:
    from bench_adapt import ADAPT_RIG_SEED, adapt_line

    from pendkit.adapt.rigs import twin_rig
    from pendkit.adapt.session import AdaptConfig, adapt
    from pendkit.sim.randomize import held_out_rigs

    minimum, seed = int(sys.argv[1]), int(sys.argv[2])
    hidden = held_out_rigs(1, ADAPT_RIG_SEED)[0]
    config = AdaptConfig(min_excitation_episodes=minimum, excitation_episodes=max(6, minimum), candidates=(),
                         twin_episodes=0, budget_s=None, seed=seed, evaluation_episodes=3)
    with tempfile.TemporaryDirectory() as work:
        rig = twin_rig(hidden.params, hidden.network, hidden.residual_offset_counts)
        report = adapt(rig, Path(work) / "out", config, say=lambda _: None)
    found = report["identified"]
    print(f"min={minimum} seed={seed} {adapt_line('hidden-00', hidden, report)} "
          f"loop_error_deg={found['servo_full_torque_error_deg']:.2f}/{hidden.params.servo_full_torque_error_deg:.2f} "
          f"servo_damping={found['servo_damping_ratio']:.2f}/{hidden.params.servo_damping_ratio:.2f}", flush=True)


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py

    print_header()
    main()
