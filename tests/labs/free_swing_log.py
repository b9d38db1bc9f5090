"""Lab 03's free swing as the realistic twin logs it (from 0.5 rad, the arm held), for the tests that read it."""

import math
import tempfile
from pathlib import Path

import pendkit
from pendkit import encoder
from pendkit.telemetry.log import readings_from_log


def logged_free_swing(steps: int):
    """(times in s, angles wrapped to [-pi, pi), the logged readings) of `steps` control steps."""
    folder = tempfile.mkdtemp()
    env = pendkit.make(fidelity="realistic", log_dir=folder)
    env.reset(seed=0, options={"start": "rest", "pendulum_angle_rad": 0.5})
    for _ in range(steps):
        env.step(0)
    env.close()
    readings = readings_from_log(str(Path(folder) / "episode-0001.jsonl"))
    angles = (encoder.counts_to_rad(readings.position_counts) + math.pi) % (2 * math.pi) - math.pi
    return readings.millis / 1000, angles, readings
