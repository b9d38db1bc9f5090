"""Lab 10, control on the device: public tests."""

from __future__ import annotations

import math
import struct

from pendkit.device.controller_blob import pack
from pendkit.device.onboard import OnboardController
from pendkit.grading.core import Failed, expect, task
from pendkit.grading.on_rigs import checked_blob, judge_blob
from pendkit.grading.prelab import prelab_task
from pendkit.grading.written import written

# pendkit modules that load matplotlib and python-control are imported inside the functions that use them: importing
# this module does not need them (start-up).

prelab_task("10", ("round_trip_ms", "readings_per_decision", "heartbeat_ms"))
model = task("10.pendulum_acceleration", function="pendulum_acceleration", title="The estimate's model")
chunks = task("10.upload_chunks", function="upload_chunks", title="Upload chunks")
deploy = task("10.deploy", function="deployed_blob", title="Your controller, judged on a rig")
written("10.on_device_report", "On-device report", points=4)

W0, DAMPING, COUPLING = 5.9, 0.73, 1.22  # the kit's rig: rad/s, 1/s, per unit inertia


def reference(angle, rate, push, w0=W0, damping=DAMPING, coupling=COUPLING) -> float:
    return -w0**2 * math.sin(angle) - damping * rate - coupling * math.cos(angle) * push


def a_number(got, call: str) -> float:
    try:
        value = float(got)
    except (TypeError, ValueError):
        raise Failed(f"{call} should return a number (rad/s^2), got {type(got).__name__}") from None
    if not math.isfinite(value):
        raise Failed(f"{call} should return a finite number, got {value}")
    return value


MISTAKES = {
    "the arm's push is missing: - coupling cos(angle) * arm acceleration": lambda a, w, p: reference(a, w, 0.0),
    "the arm's push has the wrong sign": lambda a, w, p: reference(a, w, -p),
    "sine and cosine are swapped": lambda a, w, p: -W0**2 * math.cos(a) - DAMPING * w - COUPLING * math.sin(a) * p,
    "gravity has the wrong sign (it pulls the pendulum down, towards 0)":
        lambda a, w, p: reference(a, w, p) + 2 * W0**2 * math.sin(a),  # +w0^2 sin (flipping w0 squares away)
    "the damping has the wrong sign (it slows the pendulum)": lambda a, w, p: reference(a, w, p, damping=-DAMPING),
}
CASES = [(0.4, 2.0, 10.0), (2.5, -3.0, -20.0), (math.pi - 0.1, 0.5, 5.0), (-1.2, 6.0, 30.0)]


@model.test(points=3, hint="J alpha'' = -m g l sin(alpha) - b alpha' - m r l cos(alpha) phi'', divided by J.")
def the_pendulums_row(fn, rng):
    for angle, rate, push in CASES:
        call = f"pendulum_acceleration({angle:.3f}, {rate}, {push}, {W0}, {DAMPING}, {COUPLING})"
        got = a_number(fn(angle, rate, push, W0, DAMPING, COUPLING), call)
        expected = reference(angle, rate, push)
        if abs(got - expected) <= 1e-9 * max(1.0, abs(expected)):
            continue
        named = [text for text, mistake in MISTAKES.items() if abs(got - mistake(angle, rate, push)) < 1e-9]
        raise Failed(f"{call}: expected {expected:.4f} rad/s^2, got {got:.4f}" + (f": {named[0]}" if named else ""))


@model.test(points=1, hint="Hanging still with the arm at rest nothing moves it; just short of upright, gravity "
                            "pulls the pendulum back down (-w0^2 sin(angle), the angle from hanging).")
def still_when_hanging_and_falling_back_near_upright(fn, rng):
    got = a_number(fn(0.0, 0.0, 0.0, W0, DAMPING, COUPLING), "pendulum_acceleration(0, 0, 0, ...)")
    expect(abs(got) < 1e-12, f"hanging still, the arm at rest: 0 rad/s^2, got {got}")
    upright = a_number(fn(math.pi - 0.01, 0.0, 0.0, W0, DAMPING, COUPLING), "pendulum_acceleration(pi - 0.01, ...)")
    message = f"0.01 rad short of upright (angle pi - 0.01) gravity pulls it back down (negative), got {upright}"
    if upright > 0:
        message += ": gravity has the wrong sign (-w0^2 sin(angle), with the angle from hanging)"
    expect(upright < 0, message)


def as_chunk_list(got, call: str) -> list[bytes]:
    if not isinstance(got, (list, tuple)) or not all(isinstance(c, (bytes, bytearray)) for c in got):
        raise Failed(f"{call} should return a list of bytes, got {type(got).__name__}")
    return [bytes(c) for c in got]


def device_takes(chunk_list: list[bytes]) -> dict:
    device = OnboardController()
    for chunk in chunk_list:
        device.chunk(chunk)
    return device.status()


def sample_blob() -> bytes:
    from pendkit.deploy.swingup_design import design_swing_up

    return pack(design_swing_up(None, "trajopt"))


@chunks.test(points=2, hint="b'PKUP' + struct.pack('<II', offset, len(blob)) + the bytes: little-endian.")
def the_device_takes_them(fn, rng):
    blob = sample_blob()
    got = as_chunk_list(fn(blob, 0, 1024), "upload_chunks(blob, 0, 1024)")
    status = device_takes(got)
    message = f"a {len(blob)}-byte blob in your {len(got)} chunks: the device accepted {status['accepted']}, " \
              f"ignored {status['ignored_chunks']} chunks, refused {status['refused']}"
    named = header_mistake(got, blob)
    expect(status["accepted"] == 1 and len(got) == 2, message + (f": {named}" if named else ""), hint=not named)


def header_mistake(chunk_list: list[bytes], blob: bytes) -> str | None:
    """What is wrong with the first chunk's header, where that is the mistake (None otherwise)."""
    first = chunk_list[0] if chunk_list else b""
    if first[:4] != b"PKUP" or len(first) < 12:
        return None
    if first[4:12] == struct.pack(">II", 0, len(blob)):
        return "the numbers are big-endian; the rig reads them little-endian ('<II')"
    if struct.unpack("<II", first[4:12])[1] != len(blob):
        return "the header's second number is the whole blob's size, not the chunk's"
    return None


@chunks.test(points=1, hint="Start at `start` and step by `chunk_bytes`: the offsets count from the blob's first byte.")
def resumes_after_a_lost_chunk(fn, rng):
    blob = sample_blob()
    first = as_chunk_list(fn(blob, 0, 256), "upload_chunks(blob, 0, 256)")
    if len(first) < 2:
        expected = math.ceil(len(blob) / 256)
        raise Failed(f"a {len(blob)}-byte blob in 256-byte chunks is {expected} chunks, got {len(first)}")
    named = header_mistake(first, blob)
    if named:  # the first test names it; the offsets may be right
        raise Failed(f"the device cannot put the chunks together: {named}", hint=False)
    rest = as_chunk_list(fn(blob, 256, 256), "upload_chunks(blob, 256, 256)")
    offsets = [struct.unpack("<I", c[4:8])[0] for c in rest if len(c) >= 8]
    expected = list(range(256, len(blob), 256))
    expect(offsets == expected, f"upload_chunks(blob, 256, 256) should send the bytes from 256 on: offsets "
                                f"{expected}, got {offsets}")
    status = device_takes([first[0], *rest])
    expect(status["accepted"] == 1, f"after the first chunk, the chunks from byte 256 should complete the blob; "
                                    f"the device accepted {status['accepted']}")


@deploy.test(points=1, hint="pack(design_swing_up(params, controller)): the bytes, for the kit's rig's servo.")
def the_device_takes_it(fn, rng):
    checked_blob(fn())


@deploy.test(points=3, timeout_s=120, hint="Both of the kit's designs hold on the kit's rig: check what you changed.")
def judged_by_the_rule(fn, rng):
    """On a rig through the class's queue when the grader has one (pendkit.grading.on_rigs), else on the twin."""

    return judge_blob(checked_blob(fn()))
