"""Virtual rigs: the twin in real time (or K times faster) behind the rig's own MQTT protocol.

Each rig is the MuJoCo twin with the firmware's logic (`TwinDevice`, the Python twin of the C++ core:
watchdog, safety stops, both action modes, periods, offset, device filter) and a network impairment
model. One `VirtualRigGroup` thread steps any number of rigs, each with its own MQTT client and
credentials, so a class without hardware, and the tests, use exactly the real path.
"""

from __future__ import annotations

import contextlib
import heapq
import json
import logging
import math
import queue
import subprocess
import sys
import threading
import time

import mujoco
import numpy as np
import paho.mqtt.client as mqtt

from pendkit.device.observation import McuObservation
from pendkit.errors import ConfigError
from pendkit.link.broker import EmbeddedBroker, free_port
from pendkit.link.diagnose import why_no_connection
from pendkit.link.driver import (
    DEFAULT_BROKER,
    BrokerAddress,
    RigLink,
    RigLinkError,
    controller_topic,
    send_without_delay,
    topics,
)
from pendkit.network import IMPAIRMENTS, NetworkImpairment, NetworkPath
from pendkit.rig import RigParams
from pendkit.sim.model import PENDULUM_JOINT, build_model
from pendkit.sim.twin_device import ENCODER_FAULTS, TwinDevice

LOG = logging.getLogger("pendkit.virtual_rig")
FIRMWARE_VERSION = "0.1.0-virtual"


class VirtualRig:
    """One rig on the broker. Start it through a `VirtualRigGroup`."""

    def __init__(self, rig: str, broker: str = DEFAULT_BROKER, params: RigParams | None = None,
                 impairment: str | NetworkImpairment = "none", username: str | None = None,
                 password: str | None = None, seed: int = 0, mount_offset_counts: int | None = None,
                 encoder_fault: str | None = None, protocol: int = 2, tls_ca: str | None = None) -> None:
        """`protocol=1` emulates a rig flashed with the authors' firmware (`DeviceScheduler`); `tls_ca`: the
        classroom CA for an `mqtts://` broker (its name checked, as the firmware checks it)."""
        if isinstance(impairment, str):
            if impairment not in IMPAIRMENTS:
                raise ConfigError(f"unknown impairment {impairment!r}; choose from {sorted(IMPAIRMENTS)}")
            impairment = IMPAIRMENTS[impairment]
        if encoder_fault not in ENCODER_FAULTS:
            raise ConfigError(f"encoder_fault must be one of {ENCODER_FAULTS}, got {encoder_fault!r}")
        self.rig, self.params = rig, params or RigParams()
        if mount_offset_counts is None:  # a rig calibrated as its RigParams say
            mount_offset_counts = self.params.encoder_offset_counts
        self.address = BrokerAddress.parse(broker)
        self.obs_topic, self.act_topic, self.status_topic = topics(rig)
        model = build_model(self.params)
        data = mujoco.MjData(model)
        self.device = TwinDevice(self.params, model, data, model.joint(PENDULUM_JOINT).qposadr[0],
                                 mount_offset_counts, protocol)
        self.device.encoder_fault = encoder_fault
        mujoco.mj_forward(model, data)
        self._network = NetworkPath(impairment, np.random.default_rng(seed))
        self._inbox: queue.SimpleQueue = queue.SimpleQueue()
        self._outbox: list[tuple[float, int, str]] = []
        self._sent = 0
        self.lost_observations = self.lost_commands = self.published = 0
        self._refusals_said = 0  # uploads the device refused, already logged
        # Rig time as the rig sees it: messages that reached it on its command topic, and when the first
        # and the last arrived (host bookkeeping never enters this count).
        self.commands_received = 0
        self.first_command_s: float | None = None
        self.last_command_s: float | None = None
        self._t0 = 0.0
        self.speed = 1.0
        self._connected = threading.Event()
        self.client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=f"pendkit-virtual-{rig}-{id(self):x}")
        if username is not None:
            self.client.username_pw_set(username, password)
        self._username, self._tls_ca, self._refused = username, tls_ca, None
        if self.address.tls or tls_ca:
            self.client.tls_set(ca_certs=tls_ca)
        self.client.will_set(self.status_topic, json.dumps({"online": False}), qos=1, retain=True)
        self.client.reconnect_delay_set(min_delay=0.1, max_delay=1)
        self.client.on_connect = self._on_connect
        self.client.on_disconnect = lambda *args: self._connected.clear()
        self.client.on_message = self._on_message

    # --- network (paho's thread) ---
    def connect(self, timeout_s: float = 5.0) -> None:
        self.client.connect_async(self.address.host, self.address.port, keepalive=5)
        self.client.loop_start()
        if not self._connected.wait(timeout_s):
            self.client.loop_stop()
            cause = why_no_connection(self.address.host, self.address.port, self.address.tls or bool(self._tls_ca),
                                      self._tls_ca, self._username, self._refused)
            raise RigLinkError(f"virtual rig {self.rig}: no connection within {timeout_s:g} s: {cause}")

    def _on_connect(self, client, userdata, flags, reason_code, properties) -> None:
        if reason_code.is_failure:
            self._refused = str(reason_code)
            LOG.warning("virtual rig %s: broker refused the connection: %s", self.rig, reason_code)
            return
        send_without_delay(client)  # as the firmware does: observations leave at once
        # As the firmware does: clear a command left retained on its topic (it would move the arm at every
        # boot), and never act on a retained one (`_on_message`).
        client.publish(self.act_topic, b"", qos=0, retain=True)
        client.subscribe(self.act_topic, qos=0)
        if self.device.scheduler.protocol == 2:  # the authors' firmware takes no controllers
            client.subscribe(controller_topic(self.rig), qos=0)
        self._connected.set()
        self.publish_status()

    def _on_message(self, client, userdata, message) -> None:
        if message.retain:  # left on the broker earlier, not sent to this rig now: never a command
            return
        now = time.monotonic()
        if _body(message.payload) != b"r":  # a request for this status is no use of the rig
            self.commands_received += 1
            self.first_command_s = now if self.first_command_s is None else self.first_command_s
            self.last_command_s = now
        self._inbox.put((now, message.payload))  # parsed by the device when it arrives there

    @property
    def impairment(self) -> NetworkImpairment:
        """The network's impairment; set it to change the WiFi mid-run (lab 09 drops it)."""
        return self._network.impairment

    @impairment.setter
    def impairment(self, value: NetworkImpairment) -> None:
        self._network.impairment = value

    @property
    def busy_s(self) -> float:
        """Wall seconds from the first command this rig received to the last: the rig time used."""
        if self.first_command_s is None:
            return 0.0
        return self.last_command_s - self.first_command_s

    @property
    def rejected_commands(self) -> int:
        return self.device.scheduler.rejected_commands

    def publish_status(self) -> None:
        status = {"firmware": FIRMWARE_VERSION, "rig": self.rig, **self.device.scheduler.status(),
                  # the device clock's origin on this machine's monotonic clock: one-way latency measurements
                  "clock_origin_s": self._t0, "speed": self.speed,
                  # what this rig received, counted here: a host measures rig time with it (`pendkit adapt`)
                  "commands_received": self.commands_received, "busy_s": round(self.busy_s, 3)}
        self.client.publish(self.status_topic, json.dumps(status), qos=1, retain=True)

    # --- simulation (the group's thread) ---
    def start_clock(self, t0: float, speed: float) -> None:
        self._t0, self.speed = t0, speed

    def _sim_ms(self, wall_s: float) -> float:
        return (wall_s - self._t0) * self.speed * 1000.0

    def advance(self, now_s: float) -> None:
        """Bring the twin up to `now_s`: deliver commands that arrived, run physics, send what is due."""
        while True:
            try:
                received, payload = self._inbox.get_nowait()
            except queue.Empty:
                break
            arrival = self._network.command_arrival_ms(self._sim_ms(received))
            if arrival is None:
                self.lost_commands += 1
                continue
            self.device.deliver(arrival, payload)
        ticks = math.floor(self._sim_ms(now_s) / self.params.physics_step_ms) - self.device.tick
        if ticks > 0:
            self.device.run(ticks, self._emit)
            self.device.handle_events_now(self._emit)  # a reading due at this very tick leaves now
        self._log_refusals()
        if self.device.scheduler.status_requested:
            self.device.scheduler.status_requested = False
            self.publish_status()
        while self._outbox and self._outbox[0][0] <= now_s:
            _, _, line = heapq.heappop(self._outbox)
            self.client.publish(self.obs_topic, line, qos=0)
            self.published += 1

    def _log_refusals(self) -> None:
        """One log line per uploaded controller the device refused (its status says why, too)."""
        onboard = self.device.mcu.onboard
        if onboard.blobs_refused != self._refusals_said:
            self._refusals_said = onboard.blobs_refused
            LOG.warning("virtual rig %s refused an uploaded controller: %s", self.rig, onboard.last_refusal)

    def _emit(self, now_ms: float, observation: McuObservation) -> None:
        delivery_ms = self._network.observation_delivery_ms(now_ms)
        if delivery_ms is None:
            self.lost_observations += 1
            return
        line = self.device.scheduler.observation_line(observation)
        due = self._t0 + delivery_ms / 1000.0 / self.speed
        self._sent += 1
        heapq.heappush(self._outbox, (due, self._sent, line))

    def next_wake_s(self) -> float:
        next_tick = self._t0 + (self.device.tick + 1) * self.params.physics_step_ms / 1000.0 / self.speed
        return min(next_tick, self._outbox[0][0]) if self._outbox else next_tick

    def close(self) -> None:
        self.client.publish(self.status_topic, json.dumps({"online": False}), qos=1, retain=True)
        self.client.loop_stop()
        self.client.disconnect()


class VirtualRigGroup:
    """Steps several virtual rigs in one thread, in real time times `speed`. A context manager."""

    def __init__(self, rigs: list[VirtualRig], speed: float = 1.0) -> None:
        if not rigs:
            raise ConfigError("a group needs at least one virtual rig")
        if not 0.1 <= speed <= 100:
            raise ConfigError(f"speed must be in [0.1, 100], got {speed}")
        self.rigs, self.speed = rigs, speed
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.late_ticks = 0
        self._failures: dict[str, tuple[str, str]] = {}  # each rig's last failure, logged once

    def start(self, connect_timeout_s: float = 5.0) -> VirtualRigGroup:
        for rig in self.rigs:
            rig.connect(connect_timeout_s)
        t0 = time.monotonic()
        for rig in self.rigs:
            rig.start_clock(t0, self.speed)
            rig.publish_status()  # now with the running clock's origin
        self._thread = threading.Thread(target=self._loop, daemon=True, name="pendkit-virtual-rigs")
        self._thread.start()
        return self

    def _loop(self) -> None:
        while not self._stop.is_set():
            now = time.monotonic()
            for rig in self.rigs:
                try:
                    rig.advance(now)
                except Exception as error:  # one rig's bug must not stop the others, nor fill the log every tick
                    said = (type(error).__name__, str(error))
                    if self._failures.get(rig.rig) != said:
                        self._failures[rig.rig] = said
                        LOG.exception("virtual rig %s failed a tick (said once until the failure changes)", rig.rig)
            wake = min(rig.next_wake_s() for rig in self.rigs)
            pause = wake - time.monotonic()
            if pause > 0:
                self._stop.wait(min(pause, 0.01))
            elif pause < -0.05:
                self.late_ticks += 1

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
        for rig in self.rigs:
            rig.close()

    def __enter__(self) -> VirtualRigGroup:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


class LocalRig:
    """An embedded broker and one virtual rig in this process: a rig for a notebook, no set-up needed.

    `rig = LocalRig(impairment="poor-wifi")`, then `pendkit.make(backend="rig", broker=rig.url, rig=rig.rig)`;
    `rig.stop()` at the end.
    """

    def __init__(self, rig: str = "r01", impairment: str | NetworkImpairment = "none", speed: float = 1.0,
                 **rig_kwargs) -> None:

        self.rig = rig
        self.broker = EmbeddedBroker(port=free_port()).start()
        self.url = self.broker.url
        self.virtual = VirtualRig(rig, self.url, impairment=impairment, **rig_kwargs)
        self.group = VirtualRigGroup([self.virtual], speed).start()

    def stop(self) -> None:
        self.group.stop()
        self.broker.stop()

    def measure_latency_ms(self, seconds: float = 2.0) -> np.ndarray:
        """One-way latencies (ms) of this rig's observations: valid here, where rig and host share a clock."""

        samples: list[float] = []
        link = RigLink(self.rig, self.url)
        original = link._on_message

        def on_message(client, userdata, message):
            original(client, userdata, message)
            if message.topic == link.obs_topic and link.newest is not None:
                millis = link.newest.received.observation.millis
                sent = self.virtual._t0 + millis / 1000.0 / self.virtual.speed
                samples.append((link.newest.receive_time_s - sent) * 1000.0)

        link.client.on_message = on_message
        link.connect()
        time.sleep(seconds)
        link.close()
        return np.array(samples)


@contextlib.contextmanager
def virtual_rig_process(broker_url: str, rig: str = "r01", settle_s: float = 1.5):
    """A virtual rig in its own process (`pendkit virtual-rig`), as a real rig is its own device; stopped
    on exit. Waits `settle_s` for it to connect and publish its status."""
    process = subprocess.Popen([sys.executable, "-m", "pendkit.cli", "virtual-rig", "--rig", rig, "--broker",
                                broker_url], stdout=subprocess.DEVNULL)
    try:
        time.sleep(settle_s)
        yield process
    finally:
        process.terminate()
        process.wait(timeout=10)


def _body(payload: bytes) -> bytes:
    """A command's body: v2 frames it as `#<seq>:<body>@<host ms>`, v1 sends it bare."""
    return payload.split(b":", 1)[-1].split(b"@", 1)[0].strip()
