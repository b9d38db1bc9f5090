"""Write the shared encoder test vectors read by pytest and by the firmware's C++ tests.

Run `python tests/vectors/make_vectors.py` after a deliberate change to the maths; a test fails when
the committed files and the library disagree.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from pendkit import encoder

HERE = Path(__file__).parent


def _frames() -> dict:
    rng = np.random.default_rng(2026)
    cases = []
    for position in (0, 1, 511, 512, 513, 1022, 1023):
        cases.append(encoder.encode_ssi_frame(position))
    cases += [encoder.encode_ssi_frame(int(p), magnet_closer=bool(c), magnet_away=bool(a))
              for p, c, a in zip(rng.integers(0, 1024, 12), rng.integers(0, 2, 12), rng.integers(0, 2, 12))]
    cases += [
        encoder.encode_ssi_frame(300, corrupt_parity=True),
        encoder.encode_ssi_frame(300, offset_compensated=False),
        encoder.encode_ssi_frame(300, cordic_overflow=True),
        encoder.encode_ssi_frame(300, linearity_alarm=True),
        encoder.encode_ssi_frame(300, magnet_closer=True, magnet_away=True),
        0x0000, 0xFFFF, 0x10000, -1,
    ]
    cases += [int(f) for f in rng.integers(0, 1 << 16, 20)]
    out = []
    for frame in cases:
        status = encoder.frame_status(frame)
        out.append({"frame": frame, "status": status,
                    "position_counts": (frame >> 6) & 1023 if status == "ok" else None})
    return {"description": "EMS-22A 16-bit SSI frames: bits 15..6 position, 5 OCF, 4 COF, 3 LIN, 2 MagINC, "
                           "1 MagDEC, 0 even parity. status is the first failed check, in the order of "
                           "`reasons`.",
            "reasons": list(encoder.FRAME_REASONS), "cases": out}


def _wrap() -> dict:
    pairs = [(0, 0), (1, 0), (0, 1), (0, 1023), (1023, 0), (10, 1010), (1010, 10), (512, 0), (0, 512),
             (513, 0), (0, 513), (767, 255), (256, 768), (700, 100)]
    rng = np.random.default_rng(7)
    pairs += [(int(a), int(b)) for a, b in rng.integers(0, 1024, (20, 2))]
    return {"description": "wrap-aware delta new - old with 1024 counts: the shorter way round; a jump of "
                           "exactly 512 keeps its sign.",
            "counts": 1024,
            "cases": [{"new": n, "old": o, "delta": int(encoder.wrap_delta_counts(n, o))} for n, o in pairs]}


def _counts_rad() -> dict:
    cases = []
    for raw, offset in [(0, 0), (512, 0), (256, 0), (1023, 0), (317, 317), (316, 317), (0, 317), (829, 317)]:
        cases.append({"raw_counts": raw, "offset_counts": offset,
                      "angle_from_bottom_rad": float(encoder.counts_to_rad(raw, offset))})
    return {"description": "raw reading and calibration offset -> angle from the bottom in [0, 2 pi)",
            "counts": 1024, "cases": cases}


def _velocity() -> dict:
    window = 4
    rng = np.random.default_rng(11)
    sequences = {}
    times = np.arange(12) * 25.0
    sequences["still"] = (times, np.full(12, 100))
    sequences["steady_forward"] = (times, (np.arange(12) * 7) % 1024)
    sequences["wrap_forward"] = (times, (1000 + np.arange(12) * 9) % 1024)
    sequences["wrap_backward"] = (times, (20 - np.arange(12) * 9) % 1024)
    sequences["fast_spin_2rev_s"] = (times, (np.arange(12) * 51) % 1024)
    jitter_times = np.cumsum(rng.integers(20, 31, 16)).astype(float)
    sequences["jittered_random"] = (jitter_times, rng.integers(0, 1024, 16))
    out = []
    for name, (t, positions) in sequences.items():
        mean, accel = encoder.firmware_velocity(positions, t, window)
        out.append({"name": name, "times_ms": [float(x) for x in t], "positions": [int(p) for p in positions],
                    "omega_rev_s": [float(x) for x in mean], "accel_rev_s2": [float(x) for x in accel]})
    return {"description": "the firmware's estimator: velocity = wrapped delta * 1000 / (1024 * dt_ms) in "
                           "rev/s, 0 for the first reading; reported omega = mean of the last `window` "
                           "velocities (buffer starts at zeros); accel = difference of the last two reported "
                           "omegas / dt_s, 0 for the first reading.",
            "window": window, "counts": 1024, "tolerance": 1e-9, "sequences": out}


def build() -> dict[str, dict]:
    return {"encoder_frames.json": _frames(), "wrap_delta.json": _wrap(), "counts_rad.json": _counts_rad(),
            "velocity.json": _velocity()}


if __name__ == "__main__":
    for filename, content in build().items():
        (HERE / filename).write_text(json.dumps(content, indent=1) + "\n")
        print(f"wrote {HERE / filename}")
