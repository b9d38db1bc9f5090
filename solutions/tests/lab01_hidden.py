"""Hidden tests for lab 01 (instructor material: never copied into labs/)."""

import math

from pendkit import encoder
from pendkit.grading import Failed, expect, outcomes, task
from pendkit.grading.core import Diagnosis, shown
from pendkit.grading.prelab import prelab_answers
from pendkit.grading.suites.lab01 import (
    alike,
    angle_message,
    angle_note,
    diagnose_position,
    parity_first,
    rejection_note,
    upright_note,
    wrap_direction_note,
)

decode = task("01.decode_frame", function="decode_frame", title="Decode an EMS-22A SSI frame")
to_angle = task("01.counts_to_angle", function="counts_to_angle", title="Counts to angle from the bottom")
wrap = task("01.wrap_delta", function="wrap_delta", title="Wrap-aware difference")


@decode.test(points=2, hidden=True, hint="400 random 16-bit patterns: each accepted exactly when its parity and "
                                         "status bits are good.")
def random_frames_match_the_reference(fn, rng):
    # which frames pass is what this test scores; the position is positions_of_clean_frames' and
    # every_position_round_trips' to score
    parity_first(fn)
    one_magnet_bit = ""
    frames = rng.integers(0, 1 << 16, 400).tolist()
    for frame, outcome in zip(frames, outcomes(fn, [(frame,) for frame in frames])):
        status = encoder.frame_status(frame)
        if isinstance(outcome.error, ValueError):
            note = rejection_note(frame, outcome.error)  # a Diagnosis where one magnet bit explains it
            if status == "ok" and isinstance(note, Diagnosis):
                one_magnet_bit = note  # one_magnet_bit_alone_is_valid's to score: this test looks past it
                continue
            expect(status != "ok", f"decode_frame(0x{frame:04X}) rejected a valid frame{note}", hint=True)
            continue
        if outcome.error is not None:
            raise Failed(f"decode_frame(0x{frame:04X}) raised {type(outcome.error).__name__} instead of ValueError")
        expect(status == "ok", f"decode_frame(0x{frame:04X}) accepted a frame with {status}")
    if one_magnet_bit:
        return ("every other frame is judged right; the valid frames with one magnet bit set that it rejected are "
                "one_magnet_bit_alone_is_valid's to score")


@decode.test(points=1, hidden=True, hint="Every one of the 1024 positions must decode.")
def every_position_round_trips(fn, rng):
    parity_first(fn)
    calls = [(encoder.encode_ssi_frame(position),) for position in range(1024)]
    for position, outcome in enumerate(outcomes(fn, calls)):
        if outcome.error is None and outcome.value != position:
            raise Failed(diagnose_position(calls[position][0], position, outcome.value, fn))
        expect(outcome.error is None, f"position {position} decoded as {outcome.error!r}")


@to_angle.test(points=1, hidden=True, hint="Results must stay in [0, 2 pi) for every reading and offset, a reading "
                                           "one count below the offset included.")
def whole_range(fn, rng):
    calls = [(316, 317), (0, 1), *(tuple(pair) for pair in rng.integers(0, 1024, (200, 2)).tolist())]
    for (raw, offset), outcome in zip(calls, outcomes(fn, calls)):
        if outcome.error is not None:
            raise Failed(f"counts_to_angle({raw}, {offset}) raised {type(outcome.error).__name__}: {outcome.error}")
        got = outcome.value
        expected = float(encoder.counts_to_rad(raw, offset))
        said = angle_message(f"counts_to_angle({raw}, {offset})", expected, got, raw, offset)
        inside = 0 <= got < 2 * math.pi
        if not inside:
            want, value = alike(expected, got)
            said = (f"counts_to_angle({raw}, {offset}) = {value} is outside [0, 2 pi) (it should be {want})"
                    + angle_note(expected, got, raw, offset))
        # the hint (stay in [0, 2 pi)) only for an answer outside it
        expect(inside and abs(got - expected) < 1e-9, said, hint=None if not inside else False)


@wrap.test(points=1, hidden=True, hint="Any step shorter than half a turn must come back exactly.")
def every_short_step(fn, rng):
    pairs = list(zip(rng.integers(0, 1024, 300).tolist(), rng.integers(-511, 512, 300).tolist()))
    calls = [((start + step) % 1024, start) for start, step in pairs]
    for (start, step), outcome in zip(pairs, outcomes(fn, calls)):
        got = outcome.error or outcome.value
        new = (start + step) % 1024
        note = wrap_direction_note(new, start, got)
        if outcome.error is None and got == new - start and got != step:
            note = ": that is the long way round; take the shorter way across the 1023 -> 0 seam"
        elif outcome.error is None and got == -step and step:
            note = ": right size, wrong sign: the difference is new - old"
        expect(got == step, f"wrap_delta({new}, {start}) should be {step}, got {shown(got)}{note}", hint=not note)


upright = task("01.angle_from_upright", function="angle_from_upright", title="Angle from upright")


@upright.test(points=1, hidden=True, hint="60 random angles, many turns either way, and the multiples of pi.")
def random_angles_and_the_seam(fn, rng):
    angles = [*rng.uniform(-40, 40, 60).tolist(), 0.0, 2 * math.pi, -2 * math.pi, math.pi, -math.pi, 4 * math.pi]
    for angle, outcome in zip(angles, outcomes(fn, [(a,) for a in angles])):
        expected = (angle % (2 * math.pi)) - math.pi
        got = outcome.value
        note = upright_note(angle, got) if outcome.error is None else ""
        want, said = alike(expected, got) if outcome.error is None else (f"{expected:.4f}", shown(outcome.error))
        expect(outcome.error is None and -math.pi <= float(got) < math.pi and abs(float(got) - expected) < 1e-9,
               f"angle_from_upright({angle:.4f}) should be {want} in [-pi, pi), got {said}" + note)


@wrap.test(points=1, hidden=True, hint="Both sides of the seam, each way round: a jump one count beyond half a "
                                      "turn wraps, one count short of it does not.")
def the_seam_exactly(fn, rng):
    # exactly half a turn (512) is half_a_turn_keeps_its_sign's to score: here its neighbours, 511 and 513
    calls = [(513, 0), (0, 513), (1023, 510), (510, 1023), (1023, 512), (512, 1023), (511, 0), (0, 511)]
    wanted = [-511, 511, -511, 511, 511, -511, 511, -511]
    results = outcomes(fn, [*calls, (10, 5)])
    flipped = results[-1].error is None and results[-1].value == -5  # old - new: every sign flips
    for (new, old), want, outcome in zip(calls, wanted, results):
        got = outcome.error or outcome.value
        message = f"wrap_delta({new}, {old}) should be {want}, got {shown(got)}"
        if outcome.error is None and got == -want and flipped:
            message += ": right size, wrong sign: the difference is new - old"
        elif outcome.error is None and got == -want:
            message += ": 511 counts is less than half a turn and keeps its sign (only jumps beyond 512 wrap)"
        elif outcome.error is None and got == new - old:
            message += ": 513 counts one way is 511 the other: a jump beyond half a turn wraps"
        elif outcome.error is None:
            message += wrap_direction_note(new, old, got)
        expect(outcome.error is None and got == want, message, hint=message.endswith(f"got {shown(got)}"))


prelab_answers("01", {"counts_per_turn": 1024, "counts_between_readings": 25.6}, how={
    "counts_per_turn": "the position is 10 bits (15..6), so 2^10 = 1024 positions per turn",
    "counts_between_readings": "1 rev/s for 25 ms is 0.025 turns, and 0.025 × 1024 = 25.6 counts"})


# --- The answer key (tests/grading/test_wrong_answers.py grades each through the tests above): a correct
# answer per task, which gets full marks, and plausible mistakes, each with words its feedback must contain.


def decode_frame(frame):
    status = encoder.frame_status(frame)
    if status != "ok":
        raise ValueError(status)
    return frame >> 6


def wrap_delta(new, old):
    return int(encoder.wrap_delta_counts(new, old))


def wrap_delta_wrapping_half_a_turn(new, old):
    delta = new - old
    if delta >= 512:
        return delta - 1024
    if delta <= -512:
        return delta + 1024
    return delta


def wrap_delta_by_modulo(new, old):
    delta = (new - old) % 1024
    if delta > 512:
        delta -= 1024
    return delta


def decode_lsb_first(frame):
    return int(f"{frame >> 6:010b}"[::-1], 2)


def decode_ignoring_parity(frame):
    status = encoder.frame_status(frame)
    if status not in ("ok", "parity"):
        raise ValueError(status)
    return frame >> 6


def decode_ignoring_status(frame):
    if bin(frame).count("1") % 2:
        raise ValueError("parity")
    return frame >> 6


def decode_with_odd_parity(frame):
    if bin(frame).count("1") % 2 == 0:
        raise ValueError("parity")
    return frame >> 6


def wrap_delta_correcting_the_wrong_way(new, old):
    delta = new - old
    if delta > 512:
        return delta + 1024
    if delta < -512:
        return delta - 1024
    return delta


def decode_rejecting_one_magnet_bit(frame):
    if frame & 0b110:
        raise ValueError("magnet")
    return decode_frame(frame)


def decode_whole_frame(frame):
    decode_frame(frame)
    return frame


def decode_off_by_one_shift(frame):
    decode_frame(frame)
    return frame >> 5


def counts_in_degrees(raw, offset):
    return ((raw - offset) % 1024) * 360 / 1024


def counts_adding_offset(raw, offset):
    return ((raw + offset) % 1024) * 2 * math.pi / 1024


def counts_reversed(raw, offset):
    """The offset minus the reading: the angle runs the other way round."""
    return ((offset - raw) % 1024) * 2 * math.pi / 1024


def decode_low_bits(frame):
    decode_frame(frame)
    return frame & 0x3FF


def counts_over_1023(raw, offset):
    return ((raw - offset) % 1024) * 2 * math.pi / 1023


def counts_mod_1023(raw, offset):
    return ((raw - offset) % 1023) * 2 * math.pi / 1023


def counts_without_wrap(raw, offset):
    return (raw - offset) * 2 * math.pi / 1024


def upright_by_atan2(angle):
    """Wraps with atan2, whose range is (-pi, pi]: +pi hanging."""
    return math.atan2(math.sin(angle - math.pi), math.cos(angle - math.pi))


def upright_by_fmod(angle):
    """math.fmod keeps a negative angle negative."""
    return math.fmod(angle, 2 * math.pi) - math.pi


CORRECT = {
    "01.decode_frame": decode_frame,
    "01.counts_to_angle": lambda raw, offset: float(encoder.counts_to_rad(raw, offset)),
    "01.angle_from_upright": lambda angle: float(encoder.angle_from_upright_rad(angle)),
    "01.wrap_delta": wrap_delta,
}

MISTAKES = [
    ("01.decode_frame", decode_lsb_first, "bits reversed"),
    ("01.decode_frame", decode_ignoring_parity, "parity"),
    ("01.decode_frame", decode_with_odd_parity, "parity check is inverted"),
    ("01.decode_frame", decode_ignoring_status, "OCF"),
    ("01.decode_frame", decode_rejecting_one_magnet_bit, "only one magnet bit"),
    ("01.decode_frame", decode_rejecting_one_magnet_bit, "and, not or", {"one_magnet_bit_alone_is_valid"}),
    ("01.decode_frame", decode_whole_frame, "whole frame"),
    ("01.decode_frame", decode_off_by_one_shift, "frame >> 6",
     {"positions_of_clean_frames", "every_position_round_trips"}),
    ("01.counts_to_angle", counts_in_degrees, "degrees"),
    ("01.counts_to_angle", counts_adding_offset, "added the offset"),
    ("01.counts_to_angle", counts_over_1023, "not 1023", {"calibrated_counts_scale_to_radians", "whole_range"}),
    ("01.counts_to_angle", counts_without_wrap, "negative"),
    ("01.counts_to_angle", counts_reversed, "the angle runs the wrong way: subtract the offset from the reading "
     "(reading - offset)", {"calibrated_counts_scale_to_radians", "readings_below_the_offset_wrap", "whole_range"}),
    ("01.counts_to_angle", counts_mod_1023, "% 1023 and / 1023", {"readings_below_the_offset_wrap", "whole_range"}),
    ("01.decode_frame", decode_low_bits, "the frame's low 10 bits",
     {"positions_of_clean_frames", "every_position_round_trips"}),
    ("01.angle_from_upright", lambda angle: angle - math.pi, "wrap into [-pi, pi)"),
    ("01.angle_from_upright", lambda angle: angle, "still the angle from the bottom"),
    ("01.angle_from_upright", lambda angle: (angle + math.pi) % (2 * math.pi) - math.pi, "hanging is pi from upright",
     {"upright_is_zero_and_sides_have_signs", "random_angles_and_the_seam"}),
    ("01.wrap_delta", lambda new, old: new - old, "long way round", {"differences_across_the_seam",
                                                                    "every_short_step"}),
    ("01.angle_from_upright", upright_by_atan2, "the interval is half-open",
     {"upright_is_zero_and_sides_have_signs", "random_angles_and_the_seam"}),
    ("01.angle_from_upright", upright_by_fmod, "math.fmod keeps the angle's sign",
     {"upright_is_zero_and_sides_have_signs", "random_angles_and_the_seam"}),
    ("01.wrap_delta", wrap_delta_correcting_the_wrong_way, "correction went the wrong way"),
    ("01.wrap_delta", lambda new, old: -wrap_delta(new, old), "wrong sign"),
    ("01.wrap_delta", lambda new, old: (new - old + 512) % 1024 - 512, "exactly half a turn"),
    ("01.wrap_delta", wrap_delta_wrapping_half_a_turn, "exactly half a turn", {"half_a_turn_keeps_its_sign"}),
    ("01.wrap_delta", wrap_delta_by_modulo, "the modulo turned -512 into +512", {"half_a_turn_keeps_its_sign"}),
    ("01.wrap_delta", lambda new, old: -wrap_delta(new, old), "new - old", {"the_seam_exactly"}),
]
