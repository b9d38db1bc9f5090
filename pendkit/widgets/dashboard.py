"""A class dashboard: every rig on a broker, from their retained status and their observation rate."""

from __future__ import annotations

import json
import threading
import time

import paho.mqtt.client as mqtt

from pendkit.link.driver import BrokerAddress
from pendkit.widgets.common import live_frontend

FLAG_NAMES = ("arm_limit", "overspin", "stuck_encoder", "watchdog")


def dashboard_rows(statuses: dict[str, str], counts: dict[str, int], seconds: float) -> list[dict]:
    """One row per rig: online, observation rate, flags, from raw status payloads and observation counts."""
    rows = []
    for rig in sorted(set(statuses) | set(counts)):
        try:
            status = json.loads(statuses.get(rig, "{}"))
        except ValueError:
            status = {}
        flags = status.get("flags", 0) if isinstance(status.get("flags", 0), int) else 0
        rows.append({"rig": rig, "online": bool(status.get("online", rig in counts)),
                     "observations_hz": round(counts.get(rig, 0) / seconds, 1) if seconds > 0 else 0.0,
                     "flags": [name for bit, name in enumerate(FLAG_NAMES) if flags & (1 << bit)],
                     "firmware": status.get("firmware", "?")})
    return rows


class ClassDashboard:
    """Listens to `pendulum-r/status/+` and `pendulum-r/obs/+` (an instructor's read-only user suffices)."""

    def __init__(self, broker: str, username: str | None = None, password: str | None = None) -> None:
        self.address = BrokerAddress.parse(broker)
        self.statuses: dict[str, str] = {}
        self.counts: dict[str, int] = {}
        self._lock = threading.Lock()
        self._since = time.monotonic()
        self.client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=f"pendkit-dashboard-{id(self):x}")
        if username is not None:
            self.client.username_pw_set(username, password)
        self.client.on_connect = lambda c, *_: c.subscribe([("pendulum-r/status/+", 0), ("pendulum-r/obs/+", 0)])
        self.client.on_message = self._on_message
        self.client.connect(self.address.host, self.address.port)
        self.client.loop_start()
        self.widget = None
        if live_frontend():
            import ipywidgets as w

            self.table = w.HTML()
            self.widget = self.table

    def _on_message(self, client, userdata, message) -> None:
        kind, rig = message.topic.split("/")[1], message.topic.split("/")[-1]
        with self._lock:
            if kind == "status":
                self.statuses[rig] = message.payload.decode("utf-8", errors="replace")
            elif kind == "obs":
                self.counts[rig] = self.counts.get(rig, 0) + 1

    def rows(self) -> list[dict]:
        """Rows since the last call (rates over that interval)."""
        with self._lock:
            now = time.monotonic()
            rows = dashboard_rows(dict(self.statuses), dict(self.counts), now - self._since)
            self.counts, self._since = {}, now
        return rows

    def show(self):
        from IPython.display import display

        rows = self.rows()
        if self.widget is not None:
            head = "".join(f"<th scope='col'>{k}</th>" for k in ("rig", "online", "observations_hz", "flags",
                                                                 "firmware"))
            body = "".join("<tr>" + "".join(f"<td>{row[k]}</td>" for k in ("rig", "online", "observations_hz",
                                                                            "flags", "firmware")) + "</tr>"
                           for row in rows)
            self.table.value = f"<table><tr>{head}</tr>{body}</table>"
            display(self.widget)
        else:
            for row in rows:
                print(row)
        return rows

    def close(self) -> None:
        self.client.loop_stop()
        self.client.disconnect()
