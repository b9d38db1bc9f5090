"""The rig's wiring diagram, drawn from the firmware's pin map (`firmware/include/pins.h`), so the picture
and the firmware cannot disagree."""

from __future__ import annotations

import re
from pathlib import Path

from pendkit.errors import ConfigError

PIN = re.compile(r"constexpr\s+uint8_t\s+(k\w+)\s*=\s*(0x[0-9A-Fa-f]+|\d+)\s*;")
REQUIRED = ("kEncoderClock", "kEncoderData", "kEncoderChipSelect", "kI2cSda", "kI2cScl", "kServoChannel",
            "kServoDriverAddress")
COLOURS = {"power": "#D55E00", "ground": "#000000", "i2c": "#0072B2", "ssi": "#009E73", "servo": "#E69F00"}


def read_pins(path: str | Path) -> dict[str, int]:
    """The constants of a pins.h, by name."""
    text = Path(path).read_text()
    pins = {name: int(value, 0) for name, value in PIN.findall(text)}
    missing = [name for name in REQUIRED if name not in pins]
    if missing:
        raise ConfigError(f"{path} lacks {', '.join(missing)}")
    return pins


def connections(pins: dict[str, int]) -> list[tuple[str, str, str, str]]:
    """(from, to, label, kind) for every wire."""
    return [
        ("supply_6v", "pca9685", "6 V servo power (V+) ", "power"),
        ("supply_6v", "pca9685", "GND", "ground"),
        ("thingplus", "pca9685", f"SDA  GPIO {pins['kI2cSda']}", "i2c"),
        ("thingplus", "pca9685", f"SCL  GPIO {pins['kI2cScl']}", "i2c"),
        ("thingplus", "pca9685", "3V3 logic + GND", "power"),
        ("pca9685", "servo", f"channel {pins['kServoChannel']} (signal, V+, GND)", "servo"),
        ("thingplus", "encoder", f"CLK  GPIO {pins['kEncoderClock']}", "ssi"),
        ("thingplus", "encoder", f"CS   GPIO {pins['kEncoderChipSelect']}", "ssi"),
        ("encoder", "thingplus", f"DO -> 10k/20k divider -> GPIO {pins['kEncoderData']}", "ssi"),
        ("thingplus", "encoder", "5 V (USB) + GND", "power"),
    ]


def draw_wiring(pins_path: str | Path, out_path: str | Path) -> Path:
    """Draw the diagram to `out_path` (PNG or SVG by extension) with alt text in its metadata."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import FancyBboxPatch

    pins = read_pins(pins_path)
    boxes = {
        "thingplus": (0.05, 0.40, "SparkFun Thing Plus\nESP32-S2"),
        "pca9685": (0.55, 0.72, f"PCA9685 servo driver\nI2C 0x{pins['kServoDriverAddress']:02X}"),
        "servo": (0.85, 0.72, "Hitec D645MW\nservo"),
        "encoder": (0.55, 0.08, "Bourns EMS-22A\nencoder (5 V)"),
        "supply_6v": (0.85, 0.40, "6 V 3 A\nsupply"),
    }
    figure = Figure(figsize=(11, 6.5))
    FigureCanvasAgg(figure)
    axes = figure.add_axes((0, 0, 1, 1))
    axes.set_xlim(0, 1.1)
    axes.set_ylim(0, 1)
    axes.axis("off")
    centres = {}
    for name, (x, y, label) in boxes.items():
        axes.add_patch(FancyBboxPatch((x, y), 0.2, 0.16, boxstyle="round,pad=0.01", facecolor="#F2F2F2",
                                      edgecolor="#333333"))
        axes.text(x + 0.1, y + 0.08, label, ha="center", va="center", fontsize=10, weight="bold")
        centres[name] = (x + 0.1, y + 0.08)
    offsets: dict[tuple[str, str], int] = {}
    for start, end, label, kind in connections(pins):
        key = tuple(sorted((start, end)))
        k = offsets.get(key, 0)
        offsets[key] = k + 1
        (x0, y0), (x1, y1) = centres[start], centres[end]
        shift = 0.025 * (k - 1.5)
        axes.plot([x0, x1], [y0 + shift, y1 + shift], color=COLOURS[kind], lw=2, zorder=0)
        axes.text((x0 + x1) / 2, (y0 + y1) / 2 + shift, label, fontsize=8, ha="center", va="center",
                  color=COLOURS[kind], bbox={"facecolor": "white", "edgecolor": "none", "pad": 1})
    axes.text(0.02, 0.97, "pendkit rig wiring (from firmware/include/pins.h)", fontsize=12, va="top")
    out = Path(out_path)
    out.parent.mkdir(parents=True, exist_ok=True)
    alt = "Wiring: " + "; ".join(f"{a} to {b}: {label}" for a, b, label, _ in connections(pins))
    figure.savefig(out, dpi=110, metadata={"Description": alt})
    return out
