"""Study: the device holds each target the bank policy decides for whole acting ticks before it takes effect.

    python benchmarks/studies/device_target_hold.py [--validation-rigs 30] [--jobs 2] [--unseen]

On the rig's device a target reaches the servo about 10 ms after it is decided (half a PWM frame), where in
training the twin's network put 15-34 ms between them. Held back one or two acting ticks (10 ms each), the
device's loop comes back inside what the policy was trained on; its observers are designed for the delay the
held targets then have. Every setting is scored on the devices of validation rigs drawn after the 12 the
policy's checkpoint was kept by (rest + 5 random starts each), the best kept (a tie to the shipped one), and
with `--unseen` the kept one runs once on the devices of the presets and held-out rigs (90 episodes). The
hold is this study's alone (the kit's device has none). Results: docs/results/robust.md.
"""

from __future__ import annotations

import contextlib
from collections import deque

# (acting ticks each target is held, the command delay its observers are designed for, ms): shipped first
SETTINGS = ((0, 10.0), (1, 10.0), (1, 20.0), (2, 20.0), (2, 30.0))


@contextlib.contextmanager
def targets_held(ticks: int):
    """Devices installed inside this block hold each decided target `ticks` acting ticks."""
    import pendkit.device.observed_policy as observed

    shipped = observed.ObservedDevicePolicy

    class HeldTargets(shipped):
        def reset(self, *args) -> None:
            super().reset(*args)
            self.held, self.acting_ticks = deque(), 0

        def tick(self, observation, now_ms: float) -> float | None:
            self.acting_ticks += 1
            decided = super().tick(observation, now_ms)
            if decided is not None:
                self.held.append((self.acting_ticks + ticks, decided))
            released = None
            while self.held and self.held[0][0] <= self.acting_ticks:
                released = self.held.popleft()[1]
            return released

    observed.ObservedDevicePolicy = HeldTargets if ticks else shipped
    try:
        yield
    finally:
        observed.ObservedDevicePolicy = shipped


def run(setting: tuple[int, float], rigs: dict) -> dict:
    """Each rig's `Evaluation` with `setting`'s blob on its device."""
    from device_observer_settings import held

    with targets_held(setting[0]):
        return held((setting[1], 0.0, 1.0), rigs)  # readings without delay, a 1 s memory: as shipped


def main() -> None:
    from device_observer_settings import choose_blind

    choose_blind(SETTINGS, run, lambda s: f"held {s[0]} ticks, observers for {s[1]:g} ms", __doc__.splitlines()[0])


if __name__ == "__main__":
    main()
