"""Hidden tests for lab 01 (instructor material: never copied into labs/)."""

import math

from pendkit import encoder
from pendkit.grading import Failed, expect, task

decode = task("01.decode_frame", function="decode_frame", title="Decode an EMS-22A SSI frame")
to_angle = task("01.counts_to_angle", function="counts_to_angle", title="Counts to angle from the bottom")
wrap = task("01.wrap_delta", function="wrap_delta", title="Wrap-aware difference")


@decode.test(points=2, hidden=True, hint="Compare your function with the frame layout on every bit pattern.")
def random_frames_match_the_reference(fn, rng):
    for frame in rng.integers(0, 1 << 16, 400).tolist():
        status = encoder.frame_status(frame)
        try:
            got = fn(frame)
        except ValueError:
            expect(status != "ok", f"decode_frame(0x{frame:04X}) rejected a valid frame")
            continue
        except Exception as error:
            raise Failed(f"decode_frame(0x{frame:04X}) raised {type(error).__name__} instead of ValueError") from error
        expect(status == "ok", f"decode_frame(0x{frame:04X}) accepted a frame with {status}")
        expect(got == frame >> 6, f"decode_frame(0x{frame:04X}) should be {frame >> 6}, got {got!r}")


@decode.test(points=1, hidden=True, hint="Every one of the 1024 positions must decode.")
def every_position_round_trips(fn, rng):
    for position in range(1024):
        got = fn(encoder.encode_ssi_frame(position))
        expect(got == position, f"position {position} decoded as {got!r}")


@to_angle.test(points=1, hidden=True, hint="Results must stay in [0, 2 pi) for every reading and offset.")
def whole_range(fn, rng):
    for raw, offset in rng.integers(0, 1024, (200, 2)).tolist():
        got = fn(raw, offset)
        expect(0 <= got < 2 * math.pi, f"counts_to_angle({raw}, {offset}) = {got!r} is outside [0, 2 pi)")
        expect(abs(got - float(encoder.counts_to_rad(raw, offset))) < 1e-9,
               f"counts_to_angle({raw}, {offset}) is wrong")


@wrap.test(points=1, hidden=True, hint="Any step shorter than half a turn must come back exactly.")
def every_short_step(fn, rng):
    for start, step in zip(rng.integers(0, 1024, 300).tolist(), rng.integers(-511, 512, 300).tolist()):
        got = fn((start + step) % 1024, start)
        expect(got == step, f"wrap_delta({(start + step) % 1024}, {start}) should be {step}, got {got!r}")
