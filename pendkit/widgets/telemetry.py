"""A rig telemetry monitor for the rig backend: observation age, step jitter, safety flags, and an e-stop."""

from __future__ import annotations

import numpy as np

from pendkit.widgets.common import live_frontend


def telemetry_summary(backend) -> dict:
    """The figures the monitor shows, from a `RigBackend` (plain data, for tests and for printing)."""
    newest = backend.link.newest
    errors_ms = np.abs(np.array(backend.step_period_errors_s[-200:])) * 1000
    return {
        "rig": backend.rig,
        "connected": backend.link.connected,
        "observation_age_ms": None if newest is None else round(1000 * backend.observation_age_now(), 1),
        "step_jitter_p99_ms": round(float(np.percentile(errors_ms, 99)), 2) if errors_ms.size else None,
        "safety_flags": sorted(newest.received.observation.flags) if newest else [],
        "received": backend.link.counters.received,
        "malformed": backend.link.counters.malformed,
        "dropped": backend.link.counters.dropped,
        "estopped": backend.estopped,
    }


class TelemetryMonitor:
    """Shows `telemetry_summary` and has a software e-stop button (stop now, ignore actions until released)."""

    def __init__(self, env) -> None:
        self.backend = env.unwrapped.backend
        if not hasattr(self.backend, "emergency_stop"):
            raise TypeError("TelemetryMonitor needs an env with backend='rig'")
        self.widget = None
        if live_frontend():
            import ipywidgets as w

            self.table = w.HTML()
            self.stop_button = w.Button(description="E-STOP", button_style="danger",
                                        tooltip="Stop the servo now (keyboard: Tab to it, then Enter)")
            self.release_button = w.Button(description="release", tooltip="Let actions through again")
            self.stop_button.on_click(lambda _: self.emergency_stop())
            self.release_button.on_click(lambda _: self.release())
            self.widget = w.VBox([w.HBox([self.stop_button, self.release_button]), self.table])

    def emergency_stop(self) -> None:
        self.backend.emergency_stop()
        self.refresh()

    def release(self) -> None:
        self.backend.release_stop()
        self.refresh()

    def refresh(self) -> dict:
        summary = telemetry_summary(self.backend)
        if self.widget is not None:
            rows = "".join(f"<tr><th scope='row'>{k}</th><td>{v}</td></tr>" for k, v in summary.items())
            self.table.value = f"<table>{rows}</table>"
        return summary

    def show(self):
        from IPython.display import display

        summary = self.refresh()
        if self.widget is not None:
            display(self.widget)
        else:
            print(summary)
