"""The host's MQTT link to one rig (paho-mqtt): commands out, the newest observation in.

paho's network thread receives in the background; every payload is decoded totally (a malformed one is
counted and logged, never raised in that thread, never changes state). The link reconnects by itself.
TCP_NODELAY is set on the socket: without it steady streaming sees 13-32 ms p99 latency.
"""

from __future__ import annotations

import logging
import socket
import threading
import time
from dataclasses import dataclass
from urllib.parse import urlparse

import paho.mqtt.client as mqtt

from pendkit.device.protocol import ProtocolError
from pendkit.errors import ConfigError, PendkitError
from pendkit.link import DEFAULT_BROKER
from pendkit.link.diagnose import rig_user_mismatch, why_no_connection, why_rig_silent
from pendkit.telemetry.log import EpisodeLog
from pendkit.telemetry.parse import ANY_DEVICE, ReadingLimits, ReceivedObservation, parse_observation

LOG = logging.getLogger("pendkit.link")
# While the stream is live, an observation older than the newest (time or v2 sequence) or further ahead than
# the time since it allows is a replayed or forged one (anyone may publish on an open broker): rejected, and
# the stream followed goes on. Two such observations in a row that follow each other are a new stream (the
# device rebooted: its clock and counters restarted) and are followed from then on, as is any observation
# after RESYNC_AFTER_S of silence.
RESYNC_AFTER_S = 1.0
FASTEST_STREAM_MS = 5.0  # no device streams faster: bounds how far the sequence can move in a given time
CLOCK_SLACK_S = 0.5  # the network's jitter: how much further the device's clock may move than ours


def send_without_delay(client: mqtt.Client) -> None:
    """TCP_NODELAY on a connected client's socket: small messages leave at once (no Nagle), as the firmware's
    `setNoDelay(true)` does on the rig."""
    sock = client.socket()
    if sock is not None and hasattr(sock, "setsockopt"):
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)


class RigLinkError(PendkitError, ConnectionError):
    """The rig or its broker cannot be reached, or has gone quiet."""


@dataclass(frozen=True)
class BrokerAddress:
    host: str
    port: int
    tls: bool

    @classmethod
    def parse(cls, url: str) -> BrokerAddress:
        """`mqtt://host:port`, `mqtts://host:port` (TLS), or `host[:port]`."""
        usage = "broker must look like mqtt://host:1883 or mqtts://host:8883 (port 1-65535)"
        if not isinstance(url, str):
            raise ConfigError(f"{usage}, got {url!r}")
        if "://" not in url:
            url = f"mqtt://{url}"
        try:  # urlparse raises on a malformed IPv6 host, .port on a port out of range
            parsed = urlparse(url)
            host, port = parsed.hostname, parsed.port
        except ValueError:
            raise ConfigError(f"{usage}, got {url!r}") from None
        if parsed.scheme not in ("mqtt", "mqtts", "tcp", "ssl") or not host or port == 0:
            raise ConfigError(f"{usage}, got {url!r}")
        tls = parsed.scheme in ("mqtts", "ssl")
        return cls(host, port or (8883 if tls else 1883), tls)

    def __str__(self) -> str:
        return f"{'mqtts' if self.tls else 'mqtt'}://{self.host}:{self.port}"


@dataclass
class LinkCounters:
    received: int = 0
    malformed: int = 0
    published: int = 0
    connects: int = 0
    disconnects: int = 0
    dropped: int = 0  # gaps in the v2 observation sequence numbers: observations lost on the way
    resyncs: int = 0  # a stream picked up afresh after silence (e.g. a device reboot)


@dataclass(frozen=True)
class Arrival:
    received: ReceivedObservation
    receive_time_s: float  # time.monotonic() when it arrived


def check_rig_id(rig: str) -> str:
    """A rig id fit for a topic: letters, digits, '-' and '_' (an MQTT wildcard such as '+' would name
    every rig at once, a '/' another topic)."""
    if not isinstance(rig, str) or not rig or len(rig) > 64 or not rig.replace("-", "").replace("_", "").isalnum():
        raise ConfigError(f"rig id {rig!r} is not a rig's name: use letters, digits, '-' or '_' (r01, r02, ...)")
    return rig


def topics(rig: str) -> tuple[str, str, str]:
    """(observations, commands, status) topics of a rig."""
    check_rig_id(rig)
    return f"pendulum-r/obs/{rig}", f"pendulum-r/act/{rig}", f"pendulum-r/status/{rig}"


def controller_topic(rig: str) -> str:
    """The topic a rig takes controller uploads on (binary chunks, `pendkit.device.onboard`; v2 firmware)."""
    check_rig_id(rig)
    return f"pendulum-r/ctl/{rig}"


def order_problem(before: ReceivedObservation, received: ReceivedObservation, elapsed_s: float) -> str | None:
    """Why `received` cannot follow `before` in a live stream `elapsed_s` later (None: it can)."""
    ahead_ms = received.observation.millis - before.observation.millis
    if ahead_ms < 0:
        return f"time went backwards: {received.observation.millis} ms after {before.observation.millis} ms"
    if ahead_ms > (elapsed_s + CLOCK_SLACK_S) * 1000:
        return f"time jumped {ahead_ms} ms ahead in {elapsed_s * 1000:.0f} ms"
    if received.version == 2 and before.version == 2:
        gap = received.observation_seq - before.observation_seq
        most = 2 + int((elapsed_s + CLOCK_SLACK_S) * 1000 / FASTEST_STREAM_MS)
        if not 1 <= gap <= most:
            return (f"observation seq {received.observation_seq} after {before.observation_seq}: expected the next "
                    f"one, at most {most} ahead")
    return None


class RigLink:
    """Connects as the host of `rig`; `publish` commands, read `newest`."""

    def __init__(self, rig: str, broker: str = DEFAULT_BROKER, username: str | None = None,
                 password: str | None = None, tls_ca: str | None = None, keepalive_s: int = 5,
                 log: EpisodeLog | None = None, limits: ReadingLimits = ANY_DEVICE, check_user: bool = True) -> None:
        """`limits`: what this rig's device can report (`ReadingLimits.for_rig(params)`); beyond it, malformed.
        `check_user`: refuse at once a classroom host user of another rig (`host-r02` for r01); the broker's ACL
        would drop its messages without a word (False: let the broker decide, as its own tests do)."""
        self.rig, self.address = rig, BrokerAddress.parse(broker)
        self.limits = limits
        self.obs_topic, self.act_topic, self.status_topic = topics(rig)
        self.counters = LinkCounters()
        self.newest: Arrival | None = None
        self._stray: ReceivedObservation | None = None  # the last observation rejected as out of order
        self.status: str | None = None
        self.status_is_live = False  # the last status was published while we listened (not the retained copy)
        self.log = log
        self._connected = threading.Event()
        self._refused: str | None = None
        mismatch = rig_user_mismatch(rig, username) if check_user else None
        if mismatch is not None:
            raise RigLinkError(mismatch)
        self.username, self._tls_ca, self._has_password = username, tls_ca, password is not None
        self.client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=f"pendkit-host-{rig}-{id(self):x}")
        if username is not None:
            self.client.username_pw_set(username, password)
        if self.address.tls or tls_ca:
            self.client.tls_set(ca_certs=tls_ca)
        self.client.reconnect_delay_set(min_delay=0.1, max_delay=1)
        self.client.on_connect = self._on_connect
        self.client.on_disconnect = self._on_disconnect
        self.client.on_message = self._on_message
        self._keepalive_s = keepalive_s

    @property
    def connected(self) -> bool:
        return self._connected.is_set()

    def connect(self, timeout_s: float = 5.0) -> None:
        """Connect and subscribe; `RigLinkError` with what to do if it does not happen in time."""
        self.client.connect_async(self.address.host, self.address.port, keepalive=self._keepalive_s)
        self.client.loop_start()
        if not self._connected.wait(timeout_s):
            self.close()
            cause = why_no_connection(self.address.host, self.address.port, self.address.tls or bool(self._tls_ca),
                                      self._tls_ca, self.username, self._refused, self._has_password,
                                      tls_asked=bool(self._tls_ca) and not self.address.tls)
            raise RigLinkError(f"no connection to the broker within {timeout_s:g} s: {cause}")

    def publish(self, text: str) -> bool:
        info = self.client.publish(self.act_topic, text, qos=0)
        if info.rc == mqtt.MQTT_ERR_SUCCESS:
            self.counters.published += 1
            if self.log is not None:
                self.log.write(time.monotonic(), "tx", self.act_topic, text)
            return True
        return False

    def publish_chunk(self, chunk: bytes) -> bool:
        """One upload chunk on the rig's controller topic (QoS 0, as commands: a lost one is resent)."""
        info = self.client.publish(controller_topic(self.rig), chunk, qos=0)
        return info.rc == mqtt.MQTT_ERR_SUCCESS

    def rigs_reporting(self, wait_s: float = 1.0) -> dict[str, str]:
        """The rigs whose retained status this user may read on the broker (all of them for the instructor,
        its own rig for a host user), each with that status: how a typo in a rig id is told from a rig that
        is off, and the room's roll call (`pendkit rigs`)."""
        seen: dict[str, str] = {}
        wildcard = self.status_topic.rsplit("/", 1)[0] + "/+"

        def on_status(client, userdata, message) -> None:
            seen[message.topic.rsplit("/", 1)[-1]] = message.payload.decode("utf-8", errors="replace")[:2000]
            if message.topic == self.status_topic:
                self._on_message(client, userdata, message)

        self.client.message_callback_add(wildcard, on_status)
        self.client.subscribe(wildcard, 0)
        time.sleep(wait_s)
        self.client.unsubscribe(wildcard)
        self.client.message_callback_remove(wildcard)
        return dict(sorted(seen.items()))

    def why_silent(self) -> str:
        """One line on why this rig does not answer (`pendkit.link.diagnose.why_rig_silent`)."""
        seen = self.rigs_reporting() if self.connected and self.status is None else None
        return why_rig_silent(self.rig, self.username, self.connected, str(self.address), self.status,
                              None if seen is None else list(seen))

    def close(self) -> None:
        self.client.loop_stop()
        self.client.disconnect()
        self._connected.clear()

    # --- paho callbacks (its network thread) ---
    def _on_connect(self, client, userdata, flags, reason_code, properties) -> None:
        if reason_code.is_failure:
            self._refused = str(reason_code)
            LOG.warning("broker %s refused the connection: %s", self.address, reason_code)
            return
        send_without_delay(client)
        client.subscribe([(self.obs_topic, 0), (self.status_topic, 0)])
        self.counters.connects += 1
        self._connected.set()

    def _on_disconnect(self, client, userdata, flags, reason_code, properties) -> None:
        self.counters.disconnects += 1
        self._connected.clear()

    def _on_message(self, client, userdata, message) -> None:
        now = time.monotonic()
        try:
            payload = message.payload.decode("ascii", errors="replace")
            if message.topic == self.status_topic:
                self.status, self.status_is_live = payload, not message.retain
                return
            received = parse_observation(message.payload, self.limits)
            self._check_order(received, now)
        except ProtocolError as error:
            self.counters.malformed += 1
            LOG.info("rig %s: rejected observation (%s)", self.rig, error)
            return
        except Exception:  # a bug must not kill paho's thread; count it as malformed
            self.counters.malformed += 1
            LOG.exception("rig %s: unexpected error decoding an observation", self.rig)
            return
        self.counters.received += 1
        self.newest = Arrival(received, now)
        if self.log is not None:
            self.log.write(now, "rx", self.obs_topic, payload)

    def _check_order(self, received: ReceivedObservation, now: float) -> None:
        """Reject what the live stream cannot have sent (see RESYNC_AFTER_S); count the observations lost
        (v2 sequence gaps) before an accepted one."""
        newest = self.newest
        if newest is None:
            return
        if now - newest.receive_time_s > RESYNC_AFTER_S:
            self.counters.resyncs += 1
            self._stray = None
            return
        problem = order_problem(newest.received, received, now - newest.receive_time_s)
        if problem is None:
            self._stray = None
            if received.version == 2 and newest.received.version == 2:
                self.counters.dropped += received.observation_seq - newest.received.observation_seq - 1
            return
        stray, self._stray = self._stray, received
        if stray is not None and order_problem(stray, received, now - newest.receive_time_s) is None:
            self.counters.resyncs += 1  # two in a row that follow each other: the device restarted
            self._stray = None
            return
        raise ProtocolError(problem)
