"""Fingerprints of fixed-seed episodes, to hold a speed change to the same trajectories: every step's
observation, reward, true joint state, ages, servo target and flags, hashed per fidelity and action mode
(the realistic twin also with losses, poor WiFi, and with the observer). Run it before and after a change;
every line must match.

    python benchmarks/studies/step_pins.py [--steps 1200]
"""

from __future__ import annotations

import argparse
import hashlib

import numpy as np

import pendkit
from pendkit.network import IMPAIRMENTS


def fingerprint(fidelity, action_mode: str, steps: int, seed: int, features: str = "measured") -> str:
    env = pendkit.make(fidelity=fidelity, action_mode=action_mode, features=features)
    observation, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    digest = hashlib.sha256(observation.tobytes())
    for _ in range(steps):
        action = int(rng.integers(0, 5)) if action_mode == "discrete" else rng.uniform(-1, 1, 1).astype(np.float32)
        observation, reward, _, truncated, info = env.step(action)
        true = info["true_state"]
        row = [*observation.tolist(), reward, true["arm_angle_rad"], true["pendulum_angle_rad"],
               true["pendulum_velocity_rad_s"], true["time_s"], info["observation_age_s"],
               info["time_since_action_s"], info["servo_target_rad"], sorted(info["safety_flags"]),
               info["observation_clipped"]]
        digest.update(repr(row).encode())
        if truncated:
            observation, _ = env.reset()
            digest.update(observation.tobytes())
    env.close()
    return digest.hexdigest()[:16]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=1200)
    args = parser.parse_args()
    poor = pendkit.FIDELITY_PRESETS["realistic"].replace(name="poor-wifi", network=IMPAIRMENTS["poor-wifi"])
    cases = [(f"{name}/{mode}", name, mode, 3, "measured") for name in ("ideal", "paper-delayed", "realistic")
             for mode in ("discrete", "continuous")]
    cases += [("realistic/estimated", "realistic", "discrete", 3, "estimated"),
              ("poor-wifi/discrete", poor, "discrete", 3, "measured"),
              ("poor-wifi/continuous", poor, "continuous", 5, "measured")]
    for label, fidelity, mode, seed, features in cases:
        print(f"episode={label} sha256={fingerprint(fidelity, mode, args.steps, seed, features)}", flush=True)


if __name__ == "__main__":
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/provenance.py
    from provenance import print_header

    print_header()
    main()
