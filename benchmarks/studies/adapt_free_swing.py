"""Study: how long must each excitation episode's free swing be? The excitation and identification of
`pendkit adapt` (at least 3 episodes, every search run, no budget) on the hidden-rig stand-ins, with the
free swing after the jumps shortened from its 90 steps; only that length changes between runs.

    python benchmarks/studies/adapt_free_swing.py FREE_STEPS SEED [RIG ...]   # e.g. 90 0, then 78 0
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))


def main() -> None:
    from bench_adapt import ADAPT_RIG_SEED

    import pendkit.adapt.excite_identify as excite_identify
    from pendkit.adapt.rigs import twin_rig
    from pendkit.adapt.session import AdaptConfig
    from pendkit.sim.randomize import held_out_rigs

    free_steps, seed = int(sys.argv[1]), int(sys.argv[2])
    names = [int(k) for k in sys.argv[3:]] or list(range(6))
    plain = excite_identify.schedule
    excite_identify.schedule = lambda *args: [dataclasses.replace(e, free_steps=free_steps) for e in plain(*args)]
    config = AdaptConfig(seed=seed)
    for k, hidden in enumerate(held_out_rigs(6, ADAPT_RIG_SEED)):
        if k not in names:
            continue
        rig = twin_rig(hidden.params, hidden.network, hidden.residual_offset_counts)
        started = time.time()
        found = excite_identify.excite_and_identify(rig, config, math.inf, lambda _: None, None)
        fit, true = found.identification.params, hidden.params
        speed = fit.servo_speed_s_per_60deg / true.servo_speed_s_per_60deg - 1
        omega = fit.pendulum_natural_frequency_rad_s / true.pendulum_natural_frequency_rad_s - 1
        damping = fit.pendulum_damping_n_m_s_per_rad / true.pendulum_damping_n_m_s_per_rad - 1
        rig_s = rig.seconds()
        print(f"free={free_steps} seed={seed} rig=hidden-{k:02d} episodes={len(found.jumps)} rig_s={rig_s:.1f} "
              f"speed_error={speed:+.1%} omega_error={omega:+.1%} pendulum_damping_error={damping:+.0%} "
              f"identified_err={max(abs(speed), abs(omega)):.3f} wall_s={time.time() - started:.0f}", flush=True)


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py

    print_header()
    main()
