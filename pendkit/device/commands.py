"""Commands from host to device, v1 (the authors') and v2 (ours), parsed strictly.

    command := [ "#" seq ":" ] body [ "@" host_ms ]      seq, host_ms: decimal, 0..4294967295
    body    := a | s | d | f | g                         fast left, slow left, stop, slow right, fast right
             | m<0..4>                                  the same five by index (paper's "m<a>")
             | b<float -1..1>                           continuous target
             | o<0..1023> | u<5..1000> | i<5..1000>     encoder offset; streaming, acting period (ms)
             | e<float 0..0.999>                        device-side filter coefficient
             | z | x | y | c | v                        one observation, stream on, off, continuous, discrete
             | h | r                                    v2: heartbeat; republish the retained status
             | w<50..5000> | p<float 0 or 0.5..20>      v2: watchdog timeout ms; over-spin limit rev/s (0 = off)
             | n<1..16>                                 v2: velocity window (the rate is the mean of the last n
                                                          per-reading rates; the history restarts)
             | k<0..1>                                  v2: stop (0) or start (1) the uploaded controller
                                                          (pendkit.device.onboard; uploads are binary chunks)

A float is `[+-]digits[.digits]` or `[+-].digits` (no exponent, no nan or inf), at most 16 characters.
The firmware's C++ parser follows the same grammar; tests/vectors/commands.json holds both to it.
Every error is a `ProtocolError` whose `reason` is one of REASONS.
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass

from pendkit.backend_contract import ServoCommand
from pendkit.device.logic import action_increments_counts
from pendkit.device.protocol import ProtocolError
from pendkit.rig import RigParams

MAX_COMMAND_LENGTH = 64
MAX_UINT32 = 4294967295
REASONS = ("empty", "too_long", "bad_framing", "unknown_command", "bad_number", "out_of_range")
ACTION_LETTERS = "dsafg"  # by action index: stop, left slow, left fast, right slow, right fast
LETTER_ACTIONS = {letter: index for index, letter in enumerate(ACTION_LETTERS)}
FLAGS_ONLY = {"z": "observe_once", "x": "stream_on", "y": "stream_off", "c": "continuous_mode",
              "v": "discrete_mode", "h": "heartbeat", "r": "status"}
INTEGER_SETTINGS = {"o": ("encoder_offset", 0, 1023), "u": ("streaming_period", 5, 1000),
                    "i": ("acting_period", 5, 1000), "w": ("watchdog_timeout", 50, 5000), "m": ("action", 0, 4),
                    "n": ("velocity_window", 1, 16), "k": ("onboard", 0, 1)}
FLOAT_SETTINGS = {"b": ("target", -1.0, 1.0), "e": ("filter", 0.0, 0.999), "p": ("overspin_limit", 0.0, 20.0)}
_FLOAT = re.compile(r"[+-]?([0-9]+(\.[0-9]*)?|\.[0-9]+)")
_INTEGER = re.compile(r"[+-]?[0-9]+")
_FRAMED = re.compile(r"#([0-9]{1,10}):(.*)", re.DOTALL)


@dataclass(frozen=True)
class DeviceCommand:
    """A parsed command. `kind` names it; `value` holds its number (action index for discrete ones)."""

    kind: str
    value: float = 0.0
    seq: int | None = None
    host_ms: int | None = None


def _error(reason: str, detail: str) -> ProtocolError:
    error = ProtocolError(f"{reason}: {detail}")
    error.reason = reason
    return error


@functools.lru_cache(maxsize=4096)  # a pure function of the text: a rig's stream of the same few commands
def parse_command(payload: str | bytes) -> DeviceCommand:
    """Parse one command; `ProtocolError` (with `.reason`) if it breaks the grammar."""
    if isinstance(payload, bytes):
        try:
            payload = payload.decode("ascii")
        except UnicodeDecodeError:
            raise _error("bad_framing", "not ASCII") from None
    text = payload.rstrip("\r\n ")
    if not text:
        raise _error("empty", "no command")
    if len(text) > MAX_COMMAND_LENGTH:
        raise _error("too_long", f"{len(text)} characters, at most {MAX_COMMAND_LENGTH}")
    seq = host_ms = None
    if text.startswith("#"):
        framed = _FRAMED.fullmatch(text)
        if not framed:
            raise _error("bad_framing", f"expected #<seq>:<command>, got {text!r}")
        seq, text = _uint32(framed.group(1)), framed.group(2)
    if "@" in text:
        text, _, stamp = text.partition("@")
        if not (stamp.isascii() and stamp.isdigit()) or len(stamp) > 10:
            raise _error("bad_framing", f"expected @<host ms> at the end, got @{stamp!r}")
        host_ms = _uint32(stamp)
    if not text:
        raise _error("empty", "no command after the framing")
    letter, argument = text[0], text[1:]
    if letter in LETTER_ACTIONS and not argument:
        return DeviceCommand("action", LETTER_ACTIONS[letter], seq, host_ms)
    if letter in FLAGS_ONLY and not argument:
        return DeviceCommand(FLAGS_ONLY[letter], 0.0, seq, host_ms)
    if letter in INTEGER_SETTINGS:
        kind, low, high = INTEGER_SETTINGS[letter]
        if not _INTEGER.fullmatch(argument) or len(argument) > 11:
            raise _error("bad_number", f"{letter!r} needs an integer, got {argument!r}")
        value = int(argument)
    elif letter in FLOAT_SETTINGS:
        kind, low, high = FLOAT_SETTINGS[letter]
        if len(argument) > 16 or not _FLOAT.fullmatch(argument):
            raise _error("bad_number", f"{letter!r} needs a decimal number, got {argument!r}")
        value = float(argument)
        if kind == "overspin_limit" and 0 < value < 0.5:
            raise _error("out_of_range", f"over-spin limit must be 0 (off) or 0.5..20 rev/s, got {value}")
    else:
        raise _error("unknown_command", f"no command {text[:8]!r}")
    if not low <= value <= high:
        raise _error("out_of_range", f"{letter!r} takes {low}..{high}, got {value}")
    return DeviceCommand(kind, float(value), seq, host_ms)


def _uint32(digits: str) -> int:
    value = int(digits)
    if value > MAX_UINT32:
        raise _error("bad_framing", f"{digits} does not fit in 32 bits")
    return value


def command_body(command: ServoCommand, params: RigParams) -> str:
    """The command's body as both protocols spell it: a/s/d/f/g for a discrete action, b<target> otherwise."""
    if command.mode == "continuous":
        return f"b{command.target_unit:.4f}"
    index = command.action
    if index is None:  # a hand-made command: only the five actions have letters
        increments = action_increments_counts(params)
        if command.increment_counts not in increments:
            raise ProtocolError(f"no action moves {command.increment_counts} counts a tick; the actions move "
                                f"{increments}")
        index = increments.index(command.increment_counts)
    return ACTION_LETTERS[index]


def frame_command(body: str, version: int, seq: int = 0, host_ms: int = 0) -> str:
    """v1: the body alone (the authors' firmware knows nothing else); v2: `#<seq>:<body>@<host ms>`."""
    if version == 1:
        return body
    return f"#{seq % (MAX_UINT32 + 1)}:{body}@{host_ms % (MAX_UINT32 + 1)}"
