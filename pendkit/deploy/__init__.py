"""Deployment: the agents' and the controllers' work taken to a rig, over the device's model (`pendkit.device`).

- `guarded`: a controller run from the laptop behind a watchdog (lab 09's `run_guarded`);
- `export`: a trained policy or a state-feedback design as a blob the device runs itself;
- `swingup_design`: the device's own swing-up designs (energy, minimum time) as blobs;
- `on_twin`: a blob uploaded to the twin's device and run there, over the twin's network;
- `on_rig`: `pendkit deploy`'s host side: upload to a rig over MQTT, start it, keep it alive, read it.
"""

from pendkit.deploy.guarded import GuardedRun, hold_action, run_guarded

__all__ = ["GuardedRun", "hold_action", "run_guarded"]
