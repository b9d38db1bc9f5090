"""Lab 10, control on the device: public tests."""

from __future__ import annotations

import math
import struct

from pendkit.device.controller_blob import pack
from pendkit.device.onboard import CHUNK_HEADER, CHUNK_MAGIC, MAX_CHUNK_BYTES, OnboardController
from pendkit.grading.core import Diagnosis, Failed, expect, task
from pendkit.grading.on_rigs import checked_blob, judge_blob
from pendkit.grading.prelab import prelab_task
from pendkit.grading.written import written

# pendkit modules that load matplotlib and python-control are imported inside the functions that use them: importing
# this module does not need them (start-up).

prelab_task("10", ("round_trip_ms", "readings_per_decision", "heartbeat_ms"))
model = task("10.pendulum_acceleration", function="pendulum_acceleration",
             title="The estimate's model", hidden_points=1)
chunks = task("10.upload_chunks", function="upload_chunks", title="Upload chunks", hidden_points=1)
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


def _model(a, w, p, w0, d, k, gravity=math.sin, push=math.cos, w0_power=2, d_sign=-1.0, p_sign=-1.0, g_sign=-1.0):
    return g_sign * w0**w0_power * gravity(a) + d_sign * d * w + p_sign * k * push(a) * p


MISTAKES = {  # the cause, and the model with that mistake: (angle, rate, push, w0, damping, coupling) -> rad/s^2
    "the arm's push is missing: - coupling cos(angle) * arm acceleration":
        lambda a, w, p, w0, d, k: _model(a, w, 0.0, w0, d, k),
    "the arm's push has the wrong sign": lambda a, w, p, w0, d, k: _model(a, w, p, w0, d, k, p_sign=1.0),
    "sine and cosine are swapped": lambda a, w, p, w0, d, k: _model(a, w, p, w0, d, k, math.cos, math.sin),
    "gravity's term takes sin(angle), not cos(angle): -w0^2 sin(angle)":
        lambda a, w, p, w0, d, k: _model(a, w, p, w0, d, k, gravity=math.cos),
    "the arm's push takes cos(angle), not sin(angle): - coupling cos(angle) * arm acceleration (the pivot is "
    "pushed sideways, fully when the pendulum hangs)":
        lambda a, w, p, w0, d, k: _model(a, w, p, w0, d, k, push=math.sin),
    "natural_frequency_rad_s is not squared: gravity's term is -w0^2 sin(angle) (w0^2 = m g l / J)":
        lambda a, w, p, w0, d, k: _model(a, w, p, w0, d, k, w0_power=1),
    "gravity has the wrong sign (it pulls the pendulum down, towards 0)":
        lambda a, w, p, w0, d, k: _model(a, w, p, w0, d, k, g_sign=1.0),  # +w0^2 sin (flipping w0 squares away)
    "the damping has the wrong sign (it slows the pendulum)": lambda a, w, p, w0, d, k: _model(a, w, p, w0, d, k,
                                                                                                d_sign=1.0),
    "the damping term is missing: - damping * rate (the bearing's drag: small, and it hardly shows in the "
    "estimate, so this check is where it shows)": lambda a, w, p, w0, d, k: _model(a, w, p, w0, d, k, d_sign=0.0),
    "gravity's term is missing: -w0^2 sin(angle)": lambda a, w, p, w0, d, k: _model(a, w, p, w0, d, k, g_sign=0.0),
    "the arm's push lacks its cos(angle): - coupling cos(angle) * arm acceleration (the pivot is pushed "
    "sideways, fully only when the pendulum hangs)": lambda a, w, p, w0, d, k: _model(a, w, p, w0, d, k,
                                                                                     push=lambda angle: 1.0),
}
CASES = [(0.4, 2.0, 10.0), (2.5, -3.0, -20.0), (math.pi - 0.1, 0.5, 5.0), (-1.2, 6.0, 30.0)]


def model_note(fn, w0: float = W0, damping: float = DAMPING, coupling: float = COUPLING) -> str:
    """The cause of a wrong model (a `Diagnosis`): the one known wrong model `fn` agrees with on every one of
    CASES, for a rig with these constants; "" when there is none (or it raises)."""
    try:
        got = [float(fn(a, w, p, w0, damping, coupling)) for a, w, p in CASES]
    except Exception:  # noqa: BLE001 (the student's code: the test reports its own failure)
        return ""
    named = [cause for cause, mistake in MISTAKES.items()
             if all(abs(value - mistake(a, w, p, w0, damping, coupling)) < 1e-9 * max(1.0, abs(value))
                    for value, (a, w, p) in zip(got, CASES))]
    return Diagnosis(": " + named[0]) if len(named) == 1 else ""


@model.test(points=3, hint="J alpha'' = -m g l sin(alpha) - b alpha' - m r l cos(alpha) phi'', divided by J.")
def the_pendulums_row(fn, rng):
    for angle, rate, push in CASES:
        call = f"pendulum_acceleration({angle:.3f}, {rate}, {push}, {W0}, {DAMPING}, {COUPLING})"
        got = a_number(fn(angle, rate, push, W0, DAMPING, COUPLING), call)
        expected = reference(angle, rate, push)
        if abs(got - expected) <= 1e-9 * max(1.0, abs(expected)):
            continue
        raise Failed(f"{call}: expected {expected:.4f} rad/s^2, got {got:.4f}" + model_note(fn))


@model.test(points=1, hint="Hanging still with the arm at rest nothing moves it; just short of upright, gravity "
                            "pulls the pendulum back down (-w0^2 sin(angle), the angle from hanging).")
def still_when_hanging_and_falling_back_near_upright(fn, rng):
    got = a_number(fn(0.0, 0.0, 0.0, W0, DAMPING, COUPLING), "pendulum_acceleration(0, 0, 0, ...)")
    expect(abs(got) < 1e-12, f"hanging still, the arm at rest: 0 rad/s^2, got {got}" + model_note(fn))
    upright = a_number(fn(math.pi - 0.01, 0.0, 0.0, W0, DAMPING, COUPLING), "pendulum_acceleration(pi - 0.01, ...)")
    message = f"0.01 rad short of upright (angle pi - 0.01) gravity pulls it back down (negative), got {upright}"
    if upright >= 0:
        message += model_note(fn) or Diagnosis(": gravity has the wrong sign (-w0^2 sin(angle), with the angle "
                                               "from hanging)")
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


def _plural(count: int, noun: str) -> str:
    return f"{count} {noun}" if count == 1 else f"{count} {noun}s"


@chunks.test(points=2, hint="b'PKUP' + struct.pack('<II', offset, len(blob)) + the bytes: little-endian.")
def the_device_takes_them(fn, rng):
    blob = sample_blob()
    got = as_chunk_list(fn(blob, 0, 1024), "upload_chunks(blob, 0, 1024)")
    status = device_takes(got)
    message = (f"a {len(blob)}-byte blob in your {_plural(len(got), 'chunk')}: the device accepted "
               f"{status['accepted']}, ignored {_plural(status['ignored_chunks'], 'chunk')}, refused "
               f"{status['refused']}")
    named = chunk_problem(got, blob, 0)
    expect(status["accepted"] == 1 and len(got) == 2, message + (Diagnosis(f": {named}") if named else ""))


def chunk_problem(chunks, blob: bytes, start: int = 0) -> str | None:
    """None when `chunks` send `blob` from byte `start` to its end as the rig expects; else what is wrong, and
    why where a usual mistake explains it."""
    expected, previous = start, None
    for k, chunk in enumerate(chunks):
        if not isinstance(chunk, (bytes, bytearray)):
            return f"chunk {k} is a {type(chunk).__name__}, not bytes"
        if len(chunk) < CHUNK_HEADER.size or chunk[:4] != CHUNK_MAGIC:
            return f"chunk {k} does not start with {CHUNK_MAGIC!r} and its two numbers ({CHUNK_HEADER.size} bytes)"
        _, offset, total = CHUNK_HEADER.unpack_from(chunk)
        payload = bytes(chunk[CHUNK_HEADER.size:])
        if (offset, total) != (expected, len(blob)):
            return _header_problem(k, chunk, offset, total, expected, blob, start, previous, len(payload))
        if not 0 < len(payload) <= MAX_CHUNK_BYTES:
            return f"chunk {k} carries {len(payload)} bytes of the blob; a chunk carries 1 to {MAX_CHUNK_BYTES}"
        if payload != blob[offset:offset + len(payload)]:
            return f"chunk {k}'s bytes are not the blob's bytes {offset}-{offset + len(payload) - 1}"
        previous, expected = (offset, len(payload)), offset + len(payload)
    if expected != len(blob):
        return f"the chunks stop at byte {expected}; the blob has {len(blob)}: the last chunk must reach its end"
    return None


def _header_problem(k, chunk, offset, total, expected, blob, start, previous, carried) -> str:
    """What a chunk's header that the rig refuses says, and the usual mistake behind it."""
    _, big_offset, big_total = struct.unpack_from(">4sII", chunk)
    if (big_offset, big_total) == (expected, len(blob)):
        return (f"chunk {k}'s offset and size are big-endian; the rig reads little-endian "
                f"(struct.pack(\"<II\", offset, size))")
    said = f"chunk {k}'s header says offset {offset} and size {total}; the rig expects offset {expected}"
    if offset == expected:
        said = f"chunk {k}'s header says size {total}; the rig expects {len(blob)}"
        if total == len(blob) - offset:
            return said + (f": that is the bytes left from this chunk's offset (len(blob) - offset); the header "
                           f"carries the whole blob's size, len(blob) = {len(blob)}, in every chunk")
        if total == carried:
            return said + ": that is the chunk's own size; the header carries the whole blob's size, len(blob)"
        return said + " (the whole blob's size)"
    if total != len(blob):
        return said + f" (where the previous chunk ended) and size {len(blob)} (the whole blob)"
    if k == 0 and start and offset == 0:
        return said + (f": the offsets count from the blob's first byte, and a resume from byte {start} starts "
                       f"there (range(start, len(blob), chunk_bytes))")
    if previous is not None and offset > expected:
        first, size = previous
        lost = f"byte {expected} is" if offset - expected == 1 else f"bytes {expected}-{offset - 1} are"
        return said + (f": chunk {k - 1} carried {size} bytes from offset {first} but the offsets step by "
                       f"{offset - first}, so {lost} never sent; each chunk carries chunk_bytes bytes, "
                       f"blob[offset:offset + chunk_bytes] (a slice's end is left out: no - 1)")
    if previous is not None and offset < expected:
        first, size = previous
        return said + (f": chunk {k - 1} carried {size} bytes from offset {first}, more than the offsets step "
                       f"({offset - first}); each chunk carries blob[offset:offset + chunk_bytes]")
    return said + " (where the previous chunk ended)"


@chunks.test(points=1, hint="Start at `start` and step by `chunk_bytes`: the offsets count from the blob's first byte.")
def resumes_after_a_lost_chunk(fn, rng):
    blob = sample_blob()
    first = as_chunk_list(fn(blob, 0, 256), "upload_chunks(blob, 0, 256)")
    if len(first) < 2:
        expected = math.ceil(len(blob) / 256)
        raise Failed(f"a {len(blob)}-byte blob in 256-byte chunks is {expected} chunks, got {len(first)}")
    named = chunk_problem(first, blob, 0)
    if named:  # the chunks from byte 0 already fail, and say why
        raise Failed(f"the device cannot put the chunks together: {named}", hint=False)
    rest = as_chunk_list(fn(blob, 256, 256), "upload_chunks(blob, 256, 256)")
    named = chunk_problem(rest, blob, 256)
    if named:
        raise Failed(f"upload_chunks(blob, 256, 256), the resume after a lost chunk: {named}", hint=False)
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
