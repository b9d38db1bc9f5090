"""Lab 01, encoder decoding: public tests."""

from __future__ import annotations

import math

from pendkit.encoder import encode_ssi_frame
from pendkit.grading.core import Diagnosis, Failed, NotGradable, expect, is_real, raised_name, shown, task
from pendkit.grading.prelab import prelab_task
from pendkit.grading.written import written

decode = task("01.decode_frame", function="decode_frame", title="Decode an EMS-22A SSI frame", hidden_points=3)
to_angle = task("01.counts_to_angle", function="counts_to_angle",
                title="Counts to angle from the bottom", hidden_points=1)
upright = task("01.angle_from_upright", function="angle_from_upright", title="Angle from upright", hidden_points=1)
wrap = task("01.wrap_delta", function="wrap_delta", title="Wrap-aware difference", hidden_points=2)


def _reversed_10_bits(value: int) -> int:
    return int(f"{value:010b}"[::-1], 2)


LOW_BITS = (": that is the frame's low 10 bits (status and parity among them); the position is its top 10 bits "
            "(15..6), i.e. frame >> 6")
WHOLE_FRAME = ": that is the whole frame; keep only the 10 position bits (15..6)"


def diagnose_position(frame: int, position: int, got, fn=None) -> str:
    """Why `got` is not the position of `frame`, named from its value. `fn` (the student's function) tells a
    whole frame from its low 10 bits where the two are the same number (a frame below 1024)."""
    message = f"decode_frame(0x{frame:04X}) should return {position}, got {shown(got)}"
    if got == _reversed_10_bits(position):
        return Diagnosis(message + ": that is the position with its bits reversed; the first bit clocked out "
                                   "(bit 15) is the most significant")
    if got == frame and got == frame & 0x3FF and fn is not None:
        return Diagnosis(message + _whole_or_low_bits(fn))
    if got == frame:
        return Diagnosis(message + WHOLE_FRAME)
    if got == frame & 0x3FF:
        return Diagnosis(message + LOW_BITS)
    if got in (frame >> 5, frame >> 7, (frame >> 6) + 1):
        return Diagnosis(message + ": the position is bits 15..6, i.e. frame >> 6")
    return message


def _whole_or_low_bits(fn) -> str:
    """For a frame below 1024 (its whole frame and its low 10 bits alike): which of the two `fn` returns for a
    frame above 1023."""
    probe = encode_ssi_frame(700)
    try:
        got = fn(probe)
    except Exception:  # noqa: BLE001 - then the value alone is all there is to go on
        got = None
    if got == probe & 0x3FF:
        return LOW_BITS
    if got == probe:
        return WHOLE_FRAME
    return ": that is the frame's bits 9..0 (status and parity among them); keep only the 10 position bits (15..6)"


def _rejects(fn, frame: int) -> bool:
    try:
        fn(frame)
    except ValueError:
        return True
    except NotImplementedError:
        raise
    except Exception as error:
        raise Failed(f"decode_frame(0x{frame:04X}) raised {raised_name(error)}; a bad frame should raise "
                     "ValueError") from error
    return False


def checks_odd_parity(fn) -> bool:
    """True when `fn` rejects a valid frame but accepts it with its parity bit (bit 0) flipped: the parity
    check inverted (odd instead of even)."""
    frame = encode_ssi_frame(420)
    for candidate, accepted in ((frame, False), (frame ^ 1, True)):
        try:
            fn(candidate)
        except ValueError:
            if accepted:
                return False
            continue
        except Exception:  # noqa: BLE001 - any other failure is another test's to name
            return False
        if not accepted:
            return False
    return True


def parity_first(fn) -> None:
    """Tests of valid frames say nothing more than bad_parity_is_rejected when the parity check is inverted."""
    if checks_odd_parity(fn):
        raise NotGradable("your function rejects valid frames because its parity check is inverted (see "
                          "bad_parity_is_rejected): this test needs valid frames to decode first")


def _accepts_a_good_frame(fn, test: str) -> None:
    """A rejection test is only worth points if good frames still decode (rejecting everything is wrong)."""
    parity_first(fn)
    frame = encode_ssi_frame(420)
    expect(not _rejects(fn, frame), f"decode_frame(0x{frame:04X}) rejected a valid frame: {test} only counts "
                                    "when valid frames still decode")


@decode.test(points=3, hint="Position = bits 15..6 of the 16-bit frame, most significant bit first.")
def positions_of_clean_frames(fn, rng):
    parity_first(fn)
    for position in (0, 1, 2, 511, 512, 700, 1023, *rng.integers(0, 1024, 5).tolist()):
        frame = encode_ssi_frame(int(position))
        got = fn(frame)
        expect(got == position, diagnose_position(frame, position, got, fn))


@decode.test(points=2, hint="Count the ones in all 16 bits: an odd count means a corrupted frame.")
def bad_parity_is_rejected(fn, rng):
    if checks_odd_parity(fn):
        frame = encode_ssi_frame(420)
        raise Failed(f"decode_frame(0x{frame:04X}) rejected a valid frame (an even number of ones) and accepted "
                     f"0x{frame ^ 1:04X} (an odd number): the parity is even, so an odd count of ones is the "
                     "corrupted frame; your check is inverted")
    _accepts_a_good_frame(fn, "bad_parity_is_rejected")
    for position in (0, 300, 1023):
        frame = encode_ssi_frame(position)
        for bit in (0, 6, 15):
            flipped = frame ^ (1 << bit)
            if bit == 6 or bit == 15:
                expect(_rejects(fn, flipped), f"decode_frame(0x{flipped:04X}) has an odd number of ones (bit {bit} "
                       "flipped in transit) but was accepted: did you check the even parity bit?")
            else:
                expect(_rejects(fn, flipped), f"decode_frame(0x{flipped:04X}) has a wrong parity bit but was "
                       "accepted: did you check the even parity bit?")


@decode.test(points=2, hint="OCF (bit 5) must be 1; COF (bit 4) and LIN (bit 3) must be 0; MagINC and "
                            "MagDEC (bits 2, 1) both set means the magnet is out of range.")
def bad_status_is_rejected(fn, rng):
    cases = [
        ({"offset_compensated": False}, "OCF (bit 5) is 0: the encoder has not finished starting up"),
        ({"cordic_overflow": True}, "COF (bit 4) is 1: the position is invalid"),
        ({"linearity_alarm": True}, "LIN (bit 3) is 1: the magnet is misaligned"),
        ({"magnet_closer": True, "magnet_away": True}, "MagINC and MagDEC are both 1: magnet out of range"),
    ]
    _accepts_a_good_frame(fn, "bad_status_is_rejected")
    for flags, why in cases:
        frame = encode_ssi_frame(420, **flags)
        expect(_rejects(fn, frame), f"decode_frame(0x{frame:04X}) was accepted but {why}")


@decode.test(points=1, hint="MagINC or MagDEC alone only says the magnet is moving; the reading is valid.")
def one_magnet_bit_alone_is_valid(fn, rng):
    # accepted is all this test asks: the position is positions_of_clean_frames' to score, once
    parity_first(fn)
    for flags in ({"magnet_closer": True}, {"magnet_away": True}):
        frame = encode_ssi_frame(123, **flags)
        try:
            fn(frame)
        except ValueError as error:
            raise Failed(f"decode_frame(0x{frame:04X}) was rejected ({error}) but only one magnet bit is set: "
                         "reject only when both are (and, not or)", hint=False) from error


def rejection_note(frame: int, error) -> str:
    """Why a valid frame a student's decode_frame rejected is valid: named from its status bits."""
    closer, away = frame >> 2 & 1, frame >> 1 & 1
    if closer != away:
        bit = "MagINC (bit 2)" if closer else "MagDEC (bit 1)"
        return Diagnosis(f" ({error}), but only {bit} is set: one magnet bit alone says the magnet is moving and "
                         "the reading is valid; reject only when both are set (and, not or)")
    return f" ({error}): its parity is even, OCF is 1, COF, LIN and the magnet bits are 0"


def upright_note(angle: float, got) -> str:
    """The cause of a wrong angle from upright, named from its value (a `Diagnosis`), or ""."""
    if not is_real(got) or not math.isfinite(got):
        return ""
    expected = angle % (2 * math.pi) - math.pi
    if abs(expected + math.pi) < 1e-9 and abs(got - math.pi) < 1e-9:
        return Diagnosis(": +pi is outside [-pi, pi): the interval is half-open, so hanging is -pi, never +pi")
    if abs(got - angle) < 1e-9:
        return Diagnosis(": that is still the angle from the bottom; upright is half a turn away")
    turns = (got - expected) / (2 * math.pi)
    if abs(turns - round(turns)) < 1e-9 and round(turns):
        where = f"{shown(got)} is outside [-pi, pi), {abs(round(turns))} turn{'s' if abs(round(turns)) > 1 else ''} " \
                f"{'above' if turns > 0 else 'below'} the answer"
        if abs(got - (angle - math.pi)) < 1e-9 and angle < 0:
            return Diagnosis(f": the shift by pi is right, but {where}: wrap into [-pi, pi) (Python's % gives a "
                             "result in [0, 2 pi) for a negative angle too; math.fmod keeps the angle's sign)")
        if abs(got - (angle - math.pi)) < 1e-9:
            return Diagnosis(f": the shift by pi is right, but the angle has wound past a turn, so {where}: wrap "
                             "into [-pi, pi)")
        return Diagnosis(f": {where}: wrap into [-pi, pi) (Python's % gives a result in [0, 2 pi) for a negative "
                         "angle too; math.fmod keeps the angle's sign)")
    if abs(abs(got - expected) - math.pi) < 1e-9:
        return Diagnosis(": pi away from the answer: that is the angle from the bottom, wrapped; hanging is pi from "
                         "upright, so shift by pi (angle % 2 pi - pi)")
    return ""


def alike(expected: float, got, places: int = 4) -> tuple[str, str]:
    """`expected` and `got` at the same number of decimals: `places`, or more while the two print alike (a wrong
    answer never reads as the right one); `got` as `shown` gives it when it is not a finite number."""
    if not is_real(got) or not math.isfinite(got):
        return f"{expected:.{places}f}", shown(got)
    for decimals in range(places, 12):
        want, said = f"{expected:.{decimals}f}", f"{float(got):.{decimals}f}"
        if want != said:
            break
    return want, said


def angle_message(call: str, expected: float, got, raw: int | None = None, offset: int | None = None,
                  plain: bool = False) -> str:
    """`call` should be `expected`, got `got`, both to the same decimals, with the cause where `angle_note`
    names one (`plain`: without it)."""
    want, said = alike(expected, got)
    message = f"{call} should be {want} rad, got {said}"
    return message if plain else message + angle_note(expected, got, raw, offset)


MIRRORED = ": the angle runs the wrong way: subtract the offset from the reading (reading - offset)"


def is_mirrored(expected: float, got) -> bool:
    """`got` is a turn minus `expected`: the offset minus the reading, where the reading minus the offset is
    the angle (0 and half a turn are their own mirror images, so they are never called mirrored)."""
    mirror = (2 * math.pi - expected) % (2 * math.pi)
    return is_real(got) and abs(got - expected) > 1e-9 and abs(got - mirror) < 1e-9


def angle_note(expected: float, got, raw: int | None = None, offset: int | None = None) -> str:
    """The cause of a wrong angle from the bottom, named from its value (a `Diagnosis`), or "". With the
    reading and the offset, an offset added rather than subtracted, and a turn taken as 1023 counts in the wrap as
    well as the scale, are named too."""
    if is_real(got) and math.isfinite(got):
        if raw is not None and offset and abs(got - (raw + offset) % 1024 * 2 * math.pi / 1024) < 1e-9:
            return Diagnosis(": you added the offset; subtract it")
        if is_mirrored(expected, got):
            return Diagnosis(MIRRORED)
        if abs(got - math.degrees(expected)) < 1e-3:
            return Diagnosis(": that is degrees; the lab uses radians")
        if got != expected and abs(got - expected * 1024 / 1023) < 1e-9:
            return Diagnosis(": every angle comes out 1024/1023 too large: divide by 1024 (positions per turn: "
                             "0..1023 is 1024 of them), not 1023")
        if raw is not None and abs(got - (raw - (offset or 0)) % 1023 * 2 * math.pi / 1023) < 1e-9:
            return Diagnosis(": that is % 1023 and / 1023; a turn has 1024 positions (0..1023): wrap with % 1024 "
                             "and divide by 1024, not 1023")
        if got < 0:
            return Diagnosis(": negative; wrap the difference into 0..1023 first (the % operator)")
    return ""


@to_angle.test(points=2, hint="Subtract the offset, wrap into 0..1023, then scale: 1024 counts = 2 pi rad.")
def calibrated_counts_scale_to_radians(fn, rng):
    for raw, offset, expected in [(0, 0, 0.0), (512, 0, math.pi), (256, 0, math.pi / 2), (317, 317, 0.0),
                                  (829, 317, math.pi), (600, 100, 500 * 2 * math.pi / 1024)]:
        got = fn(raw, offset)
        expect(is_real(got) and abs(got - expected) < 1e-9,
               angle_message(f"counts_to_angle({raw}, offset={offset})", expected, got, raw, offset))


@to_angle.test(points=2, hint="A reading just below the offset is just below a full turn, not negative.")
def readings_below_the_offset_wrap(fn, rng):
    # the wrap is this test's to score; the scale (radians, 1024 counts a turn) is
    # calibrated_counts_scale_to_radians': each reading is held to the function's own angle of one count
    one_count = fn(1, 0)
    scale = float(one_count) if is_real(one_count) and one_count > 0 else 2 * math.pi / 1024
    for raw, offset in [(316, 317), (0, 317), (100, 900)]:
        counts = (raw - offset) % 1024
        expected = counts * 2 * math.pi / 1024
        got = fn(raw, offset)
        ok = is_real(got) and abs(got - counts * scale) < 1e-9 * max(1.0, counts * scale)
        call = f"counts_to_angle({raw}, offset={offset})"
        if not ok and is_real(got) and abs(got - (raw + offset) % 1024 * scale) < 1e-9:
            raise Failed(angle_message(call, expected, got, plain=True) + ": you added the offset; subtract it",
                         hint=False)
        if not ok and is_real(got) and abs(got - (offset - raw) % 1024 * scale) < 1e-9:
            raise Failed(angle_message(call, expected, got, plain=True) + MIRRORED, hint=False)
        # the hint (not negative) only for an answer that is negative, or no number
        expect(ok, angle_message(call, expected, got, raw, offset),
               hint=None if not is_real(got) or got < 0 else False)
    if abs(scale - 2 * math.pi / 1024) > 1e-12:
        return (f"the wrap below the offset is right; your angle of one count, {shown(scale)}, is "
                "calibrated_counts_scale_to_radians' to score")


@upright.test(points=2, hint="Upright is half a turn from the bottom; wrap the result into [-pi, pi): -pi hanging, "
                            "never +pi.")
def upright_is_zero_and_sides_have_signs(fn, rng):
    for angle, expected in [(math.pi, 0.0), (math.pi + 0.1, 0.1), (math.pi - 0.1, -0.1), (0.0, -math.pi),
                            (0.05, -math.pi + 0.05), (2 * math.pi - 0.05, math.pi - 0.05),
                            (3 * math.pi + 0.1, 0.1), (-math.pi / 2, math.pi / 2), (-5 * math.pi, 0.0),
                            (2 * math.pi, -math.pi)]:  # hanging after a turn last: -pi, and +pi is outside
        got = fn(angle)
        ok = is_real(got) and abs(got - expected) < 1e-9
        want, said = alike(expected, got)
        message = f"angle_from_upright({angle:.3f}) should be {want} rad, got {said}"
        expect(ok, message + upright_note(angle, got))


@wrap.test(points=1, hint="Without a wrap, the difference is simply new - old.")
def plain_differences(fn, rng):
    for new, old in [(10, 5), (5, 10), (600, 400), (0, 0)]:
        got = fn(new, old)
        message = f"wrap_delta({new}, {old}) should be {new - old}, got {shown(got)}"
        if new != old and got == old - new:
            message += ": that is old - new; the difference is new - old"
        expect(got == new - old, message)


@wrap.test(points=3, hint="A jump of more than half a turn really went the short way across 1023/0.")
def differences_across_the_seam(fn, rng):
    for new, old, expected in [(0, 1023, 1), (1023, 0, -1), (10, 1010, 24), (1010, 10, -24), (3, 1020, 7)]:
        got = fn(new, old)
        message = f"wrap_delta({new}, {old}) should be {expected}, got {shown(got)}"
        if got == new - old:
            message += ": that is the long way round; take the shorter way across the 1023 -> 0 seam"
        elif got == old - new:
            message += ": that is old - new, and the long way round: subtract new - old, then wrap"
        elif is_real(got) and got == -expected:
            message += ": right size, wrong sign"
        message += wrap_direction_note(new, old, got)
        expect(got == expected, message, hint=message.endswith(f"got {shown(got)}"))


def wrap_direction_note(new: int, old: int, got) -> str:
    """Words for a seam correction applied the wrong way (adding 1024 where it should subtract)."""
    delta = new - old
    if abs(delta) > 512 and is_real(got) and got == delta + (1024 if delta > 0 else -1024):
        return (": the correction went the wrong way: a difference above +512 is really that minus 1024, "
                "one below -512 that plus 1024")
    return ""


@wrap.test(points=1, hint="The firmware wraps only jumps strictly larger than half a turn (512).")
def half_a_turn_keeps_its_sign(fn, rng):
    if fn(10, 5) == -5:
        raise Failed("wrap_delta(10, 5) gave -5: the difference is new - old (this test needs that first)")
    for new, old in [(512, 0), (0, 512)]:
        got = fn(new, old)
        message = f"wrap_delta({new}, {old}) should be {new - old}, got {shown(got)}"
        if new < old and is_real(got) and got == 512:  # (512, 0) already passed: the wrap is > 512, a % made +512
            message += (": (0 - 512) % 1024 is +512: the modulo turned -512 into +512; wrap the signed difference "
                        "new - old instead (only |d| > 512 wraps), or treat -512 apart")
        else:
            message += ": the firmware keeps exactly half a turn as it is (it wraps only |d| > 512, not >= 512)"
        expect(got == new - old, message, hint=False)


prelab_task("01", ("counts_per_turn", "counts_between_readings",))

written("01.reflection", "Reflection", points=2)
