"""Hidden tests for lab 10 (instructor material: never copied into labs/)."""

import math
import struct

from pendkit.grading import expect, task
from pendkit.grading.core import Failed
from pendkit.grading.prelab import prelab_answers
from pendkit.grading.suites.lab10 import a_number, as_chunk_list, chunk_problem, device_takes, model_note, reference

model = task("10.pendulum_acceleration", function="pendulum_acceleration", title="The estimate's model")
chunks = task("10.upload_chunks", function="upload_chunks", title="Upload chunks")

prelab_answers("10", {"round_trip_ms": 38.0, "readings_per_decision": 6.0, "heartbeat_ms": 50.0}, how={
    "round_trip_ms": "each way the median is the fixed 4 ms plus the lognormal part's 15 ms: 19 ms up (the reading) "
                     "and 19 ms down (the command), 38 ms in all (one way alone is 19)",
    "readings_per_decision": "a decision every 60 ms, a reading on every 10 ms acting tick: 60 / 10 = 6",
    "heartbeat_ms": "with two lost in a row, the heartbeats that arrive are three periods apart (not two): "
                    "3 x period <= 150 ms, so the period is at most 50 ms"})


@model.test(points=1, hidden=True, hint="Any rig (its frequency, damping and coupling), any state.")
def random_rigs_and_states(fn, rng):
    for _ in range(20):
        angle, rate, push = (float(v) for v in rng.uniform([-4, -15, -60], [4, 15, 60]))
        w0, damping, coupling = (float(v) for v in rng.uniform([3, 0, 0.5], [9, 3, 2]))
        got = a_number(fn(angle, rate, push, w0, damping, coupling), "pendulum_acceleration")
        expected = reference(angle, rate, push, w0, damping, coupling)
        expect(abs(got - expected) <= 1e-9 * max(1.0, abs(expected)),
               f"angle {angle:.3f}, rate {rate:.3f}, arm acceleration {push:.2f}, w0 {w0:.2f}, d {damping:.2f}, "
               f"coupling {coupling:.2f}: expected {expected:.4f}, got {got:.4f}"
               + model_note(fn, w0, damping, coupling))


@chunks.test(points=1, hidden=True, hint="Blobs of any size, any chunk size; the last chunk may be short.")
def any_blob_any_size(fn, rng):
    from pendkit.deploy.swingup_design import design_swing_up
    from pendkit.device.controller_blob import pack

    blob = pack(design_swing_up(None, str(rng.choice(["energy", "trajopt"]))))
    size = int(rng.integers(7, 700))
    got = as_chunk_list(fn(blob, 0, size), f"upload_chunks(blob, 0, {size})")
    too_big = [len(c) for c in got if len(c) > size + 12]
    expect(not too_big, f"chunks of at most {size} bytes of blob (+12 of header), got lengths {too_big[:3]}")
    named = chunk_problem(got, blob, 0)
    if named:
        raise Failed(f"a {len(blob)}-byte blob in {size}-byte chunks: {named}", hint=False)
    expect(device_takes(got)["accepted"] == 1, f"a {len(blob)}-byte blob in {size}-byte chunks was not accepted")


# --- The answer key (tests/grading/test_wrong_answers.py grades each through the tests above): a correct
# answer per task, which gets full marks, and plausible mistakes, each with words its feedback must contain.


def pendulum_acceleration(angle, rate, push, w0, damping, coupling, push_sign=-1.0, w0_power=2, push_trig=math.cos):
    return -w0**w0_power * math.sin(angle) - damping * rate + push_sign * coupling * push_trig(angle) * push


def upload_chunks(blob, start=0, size=1024, order="<", whole_size=True, remaining=False, short=0):
    def header_size(offset):
        return len(blob) - offset if remaining else len(blob) if whole_size else len(blob[offset:offset + size])

    return [b"PKUP" + struct.pack(order + "II", offset, header_size(offset)) + blob[offset:offset + size - short]
            for offset in range(start, len(blob), size)]


def deployed_blob(controller="trajopt", target_energy=1.0, cut_bytes=0, packed=True):
    from pendkit.control.swingup import SwingUpConfig
    from pendkit.deploy.swingup_design import design_swing_up
    from pendkit.device.controller_blob import pack

    designed = design_swing_up(None, controller, config=SwingUpConfig(target_energy=target_energy))
    if not packed:
        return designed
    blob = pack(designed)
    return blob[:len(blob) - cut_bytes]


CORRECT = {
    "10.pendulum_acceleration": lambda a, w, p, w0, d, k: pendulum_acceleration(a, w, p, w0, d, k),
    "10.upload_chunks": lambda blob, start=0, size=1024: upload_chunks(blob, start, size),
    "10.deploy": lambda: deployed_blob(),
}

MISTAKES = [
    ("10.pendulum_acceleration", lambda a, w, p, w0, d, k: pendulum_acceleration(a, w, p, w0, d, k, 1.0),
     "wrong sign"),
    ("10.pendulum_acceleration", lambda a, w, p, w0, d, k: pendulum_acceleration(a, w, 0.0, w0, d, k), "missing"),
    ("10.pendulum_acceleration", lambda a, w, p, w0, d, k: pendulum_acceleration(a, w, p, w0, d, k)
     + 2 * w0**2 * math.sin(a), "pulls the pendulum down, towards 0"),
    ("10.pendulum_acceleration", lambda a, w, p, w0, d, k: pendulum_acceleration(a, w, p, w0, 0.0, k),
     "damping term is missing", {"the_pendulums_row", "random_rigs_and_states"}),
    ("10.pendulum_acceleration", lambda a, w, p, w0, d, k: pendulum_acceleration(a, w, p, w0, d, k,
                                                                               push_trig=lambda angle: 1.0),
     "lacks its cos(angle)", {"the_pendulums_row", "random_rigs_and_states"}),
    ("10.pendulum_acceleration",
     lambda a, w, p, w0, d, k: pendulum_acceleration(a, w, p, w0, d, k) + w0**2 * math.sin(a),
     "gravity's term is missing", {"the_pendulums_row", "random_rigs_and_states",
                                   "still_when_hanging_and_falling_back_near_upright"}),
    ("10.pendulum_acceleration", lambda a, w, p, w0, d, k: pendulum_acceleration(a, w, p, w0, d, k, w0_power=1),
     "not squared", {"the_pendulums_row", "random_rigs_and_states"}),
    ("10.pendulum_acceleration", lambda a, w, p, w0, d, k: pendulum_acceleration(a, w, p, w0, d, k, push_trig=math.sin),
     "takes cos(angle), not sin(angle)", {"the_pendulums_row", "random_rigs_and_states"}),
    ("10.pendulum_acceleration", lambda a, w, p, w0, d, k: -w0**2 * math.cos(a) - d * w - k * math.cos(a) * p,
     "takes sin(angle), not cos(angle)", {"the_pendulums_row", "random_rigs_and_states",
                                          "still_when_hanging_and_falling_back_near_upright"}),
    ("10.upload_chunks", lambda blob, start=0, size=1024: upload_chunks(blob, start, size, ">"), "big-endian"),
    ("10.upload_chunks", lambda blob, start=0, size=1024: upload_chunks(blob, start, size, whole_size=False),
     "whole blob's size", {"the_device_takes_them", "resumes_after_a_lost_chunk", "any_blob_any_size"}),
    ("10.upload_chunks", lambda blob, start=0, size=1024: upload_chunks(blob, 0, size), "offsets"),
    ("10.upload_chunks", lambda blob, start=0, size=1024: upload_chunks(blob, start, size, short=1),
     "a slice's end is left out", {"the_device_takes_them", "resumes_after_a_lost_chunk", "any_blob_any_size"}),
    ("10.upload_chunks", lambda blob, start=0, size=1024: upload_chunks(blob, start, size, remaining=True),
     "the bytes left from this chunk's offset", {"the_device_takes_them", "resumes_after_a_lost_chunk",
                                                 "any_blob_any_size"}),
    ("10.deploy", lambda: deployed_blob(packed=False), "should return the blob's bytes"),
    ("10.deploy", lambda: deployed_blob(cut_bytes=7), "refused by the device's checks"),
    ("10.deploy", lambda: deployed_blob("energy", target_energy=0.6), "not solved"),
]
