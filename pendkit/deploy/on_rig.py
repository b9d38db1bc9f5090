"""`pendkit deploy`'s host side: upload a controller blob to a rig over MQTT, start it, keep it alive with
heartbeats, stream its telemetry, and stop it (Ctrl-C, or the rig's watchdog when this side goes away)."""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable

from pendkit.deploy.on_twin import DeployError
from pendkit.device.commands import frame_command
from pendkit.device.onboard import blob_chunks
from pendkit.features import SOLVED_TAIL_STEPS, UPRIGHT_RAD
from pendkit.link.rig_backend import is_servo_counts_range, servo_mismatch

HEARTBEAT_S = 0.05  # a third of the watchdog (150 ms by default): one or two lost heartbeats do not stop it
CHUNK_PAUSE_S = 0.002  # a rig's MQTT buffer takes one chunk at a time


class RigSession:
    """Commands and status over one `RigLink`, with v2 framing and sequence numbers."""

    def __init__(self, link) -> None:
        self.link, self.seq = link, 0

    def command(self, body: str) -> None:
        self.seq += 1
        self.link.publish(frame_command(body, 2, self.seq, int(time.monotonic() * 1000)))

    def status(self, wait_s: float = 2.0, asks: int = 3) -> dict:
        """A status the rig publishes now (after `r`, asked again up to `asks` times: a lost request or a busy
        laptop must not look like a rig that is off); {} when none comes."""
        for _ in range(asks):
            self.link.status_is_live = False
            self.command("r")
            deadline = time.monotonic() + wait_s
            while time.monotonic() < deadline and not self.link.status_is_live:
                time.sleep(0.01)
            if self.link.status_is_live:
                try:
                    return json.loads(self.link.status)
                except ValueError:
                    return {}
        return {}


CONTROLLER_STATUS_FIELDS = {"accepted": int, "refused": int, "received": int, "total": int, "bytes": int,
                            "running": bool, "last_refusal": str}


def controller_status(session: RigSession) -> dict:
    status = session.status()
    if not isinstance(status, dict):
        status = {}
    if not status:  # the authors' firmware ignores `r`: its retained status still says what it is
        try:
            status = json.loads(session.link.status or "{}")
        except ValueError:
            status = {}
        if not isinstance(status, dict) or status.get("protocol") != 1:
            status = {}
    if not status:
        raise DeployError(session.link.why_silent())
    if "controller" not in status:
        raise DeployError(f"rig {session.link.rig} runs firmware without on-device controllers (protocol "
                          f"{str(status.get('protocol', '?'))[:20]}): flash the kit's firmware (docs/on-device.md)")
    controller = status["controller"]
    wrong = ([name for name, kind in CONTROLLER_STATUS_FIELDS.items()
              if not isinstance(controller.get(name), kind) or (kind is int and isinstance(controller[name], bool))]
             if isinstance(controller, dict) else ["controller"])
    if wrong:
        raise DeployError(f"rig {session.link.rig}'s status is malformed ({', '.join(wrong)} not as the firmware "
                          "writes them): a forged status, or not the kit's firmware; on an open broker anyone may "
                          "publish on a rig's topics (use the classroom broker's ACLs, docs/protocol.md)")
    return controller


def servo_range_problem(status: dict, params, rig: str = "the rig") -> str | None:
    """Why a controller designed for `params` must not drive the rig whose status this is (None: it may)."""
    device_range = status.get("servo_counts_range") if isinstance(status, dict) else None
    if device_range is None:
        return None  # the authors' firmware does not say: nothing to compare
    if not is_servo_counts_range(device_range):
        return f"its status says servo_counts_range {str(device_range)[:40]}, not [min, max] counts (malformed)"
    return servo_mismatch(device_range, params, rig, "the controller was designed")


def upload_to_rig(session: RigSession, blob: bytes, rounds: int = 10, chunker=blob_chunks) -> int:
    """Send `blob`, resuming after lost chunks from where the rig says it got to; the chunks sent.
    `DeployError` with the rig's reason when it refuses the blob. `chunker(blob, start)` makes the chunks
    (lab 10 plugs in a student's)."""
    before = controller_status(session)
    start, sent = 0, 0
    for _ in range(rounds):
        for chunk in chunker(blob, start):
            session.link.publish_chunk(bytes(chunk))
            sent += 1
            time.sleep(CHUNK_PAUSE_S)
        status = controller_status(session)
        if status["refused"] > before["refused"]:
            raise DeployError(f"the rig refused the controller: {status['last_refusal']}")
        if status["accepted"] > before["accepted"] and status["bytes"] == len(blob):
            return sent
        start = status["received"] if status["total"] == len(blob) else 0
    raise DeployError(f"the controller did not arrive whole after {rounds} rounds ({sent} chunks): check the WiFi")


def run_on_rig(session: RigSession, seconds: float | None = None,
               report: Callable[[str], None] = print, report_every_s: float = 1.0,
               on_heartbeat: Callable[[float], None] | None = None) -> dict:
    """Start the uploaded controller and keep it alive until `seconds` pass or Ctrl-C; then stop it and hold
    the servo. Returns what happened: seconds run, telemetry received, the pendulum's last position.
    `on_heartbeat(elapsed_s)` is called at every heartbeat (to sample the telemetry)."""
    link = session.link
    started = time.monotonic()
    received_before = link.counters.received
    next_report = next_start_check = started
    running = False
    try:
        # not `run_episode`: no env here, only the link's heartbeats while the device's controller runs
        while seconds is None or time.monotonic() - started < seconds:
            now = time.monotonic()
            if not running and now >= next_start_check:
                session.command("k1")  # again until the rig says it runs (a lost k1 starts nothing)
                running = bool(controller_status(session)["running"])
                next_start_check = time.monotonic() + 0.5
            else:
                session.command("h")
                if on_heartbeat is not None:
                    on_heartbeat(now - started)
            if now >= next_report and link.newest is not None:
                report(_telemetry_line(link, now - started))
                next_report = now + report_every_s
            time.sleep(HEARTBEAT_S)
    except KeyboardInterrupt:
        report("stopping (Ctrl-C)")
    finally:
        stop(session)
    newest = link.newest
    return {"seconds": round(time.monotonic() - started, 2), "started": running,
            "telemetry": link.counters.received - received_before,
            "last_position_counts": None if newest is None else newest.received.observation.position_counts}


def stop(session: RigSession, attempts: int = 3) -> bool:
    """Stop the controller and hold the servo (`k0`, `d`), until the rig says it stopped; False when it never
    says so (its watchdog stops the servo without heartbeats anyway)."""
    for _ in range(attempts):
        session.command("k0")
        session.command("d")
        status = session.status(wait_s=1.0, asks=1)
        if status and not status.get("controller", {}).get("running", False):
            return True
    return False


def angle_from_upright_rad(link) -> float:
    """The newest reading's pendulum angle from upright, in [-pi, pi)."""
    counts = link.newest.received.observation.position_counts
    return (counts * 2 * math.pi / 1024) % (2 * math.pi) - math.pi


def wait_until_still(session: RigSession, speed: float = 1.0, still_counts: int = 3, still_s: float = 1.0,
                     timeout_s: float = 60.0) -> bool:
    """Hold the arm (heartbeats while the servo stays put) until the encoder stays within a few counts for
    `still_s` of the rig's time; False if it does not within `timeout_s`."""
    window: list[int] = []
    wanted = round(still_s / 0.05)
    deadline = time.monotonic() + timeout_s / speed
    while time.monotonic() < deadline:
        session.command("h")
        time.sleep(0.05 / speed)
        if session.link.newest is None:
            continue
        window = (window + [session.link.newest.received.observation.position_counts])[-wanted:]
        if len(window) == wanted and max(window) - min(window) <= still_counts:
            return True
    return False


def device_episode(session: RigSession, steps: int, step_s: float, speed: float = 1.0) -> list[float]:
    """One episode of the uploaded controller from a pendulum hanging still: stop, wait until still, start
    (again until the rig says it runs), then heartbeats; the pendulum's angle from upright every control
    step, from the telemetry. `speed`: a virtual rig's time per wall second."""
    stop(session)
    wait_until_still(session, speed)
    link = session.link
    while not session.status().get("controller", {}).get("running"):
        session.command("k1")
    angles = [angle_from_upright_rad(link)]
    next_s = time.monotonic()
    for _ in range(steps):
        next_s += step_s / speed
        session.command("h")
        time.sleep(max(0.0, next_s - time.monotonic()))
        angles.append(angle_from_upright_rad(link))
    stop(session)
    return angles


def deploy_verdict(samples: list[tuple[float, float]], control_step_s: float) -> str:
    """The kit's rule on one deployed run, from (seconds since start, angle from upright) samples: held when
    every sample of the rule's tail (its last 200 control steps, 4 s at 20 ms) is within 0.3 rad of upright.
    The line ends as `pendkit eval`'s does: `solved=K/1 median_upright_s=X`."""
    tail_s = SOLVED_TAIL_STEPS * control_step_s
    if not samples:
        return "verdict: not judged (no telemetry arrived); solved=0/1 median_upright_s=-"
    times = [t for t, _ in samples]
    outside = [t for t, angle in samples if abs(angle) >= UPRIGHT_RAD]
    upright_since = samples[0][0] if not outside else next((t for t in times if t > outside[-1]), None)
    ran_s = times[-1] - times[0]
    held = upright_since is not None and times[-1] - upright_since >= tail_s
    if held:
        return (f"verdict: held (within {UPRIGHT_RAD:g} rad of upright from {upright_since:.2f} s to the end, "
                f"{ran_s:.1f} s run); solved=1/1 median_upright_s={upright_since:.2f}")
    why = (f"ran {ran_s:.1f} s, the rule needs the last {tail_s:g} s upright: give --seconds longer" if
           ran_s < tail_s else f"not within {UPRIGHT_RAD:g} rad of upright for the last {tail_s:g} s")
    return f"verdict: not held ({why}); solved=0/1 median_upright_s=-"


def _telemetry_line(link, elapsed_s: float) -> str:
    observation = link.newest.received.observation
    from_upright = math.degrees(((observation.position_counts / 1024) * 2 * math.pi) % (2 * math.pi) - math.pi)
    flags = ",".join(sorted(observation.flags)) or "-"
    return (f"t={elapsed_s:5.1f}s pendulum {from_upright:+6.1f} deg from upright, servo {observation.servo_counts}, "
            f"flags {flags}, telemetry {link.counters.received}")
