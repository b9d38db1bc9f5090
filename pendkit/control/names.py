"""The classical swing-up controllers by name: one registry the CLI, the device's designs, adaptation and
the demos read (a new controller is a row here, then its design in `pendkit.deploy.swingup_design` and its
host-side class in `pendkit.demo.CONTROLLERS`)."""

from __future__ import annotations

# name -> how prose calls it
SWING_UP_CONTROLLERS: dict[str, str] = {
    "energy": "energy",  # energy pumping (Astrom & Furuta 2000), caught by LQR
    "trajopt": "minimum-time",  # the fastest bang-bang plan, tracked by time-varying LQR
}
CONTROLLER_NAMES: tuple[str, ...] = tuple(SWING_UP_CONTROLLERS)
