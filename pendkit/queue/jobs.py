"""What a team may submit, checked at submission (`make_job`, which the server calls): nothing that fails here
reaches a rig, and every blob passes the device's own checks first.

| kind | options | payload | runs on the rig |
|---|---|---|---|
| `controller` | `controller` (energy, trajopt); `preset` or `params` | none | the swing-up, designed here |
| `blob` | `preset` or `params`: the servo it was made for (default the kit's rig) | a `.pkcb` | the blob |
| `policy` | `policy`: a shipped policy the device runs | none | the policy as its device blob |
| `excitation` | `episodes` (6), `loop_episodes` (0) | none | `pendkit adapt`'s excitation, handed back |

(`params`: RigParams' fields, as `RigParams.save` writes them.)

Judged jobs take `episodes` (the kit's rule: 10, each from rest after the rig's reset) and `episode_steps` (500
control steps); every job takes `time_limit_s`, counted in the rig's own seconds (a virtual rig at 10x uses a
tenth of it in wall time). A job made for a servo runs only on rigs whose firmware reports that servo's range.
"""

from __future__ import annotations

import math
import zlib

from pendkit.agents.policy_artifact import policy_artifact
from pendkit.agents.policy_rule import RULE_STARTS
from pendkit.checks import is_finite_number
from pendkit.deploy.controllers import CONTROLLER_NAMES
from pendkit.deploy.learned_blob import learned_policy_blob
from pendkit.device.controller_blob import BlobError, pack, parse
from pendkit.device.onboard import RUNNABLE_KINDS
from pendkit.env_name import EPISODE_STEPS
from pendkit.errors import ConfigError
from pendkit.features import SOLVED_TAIL_STEPS
from pendkit.rig import SERVO_PRESETS, RigParams

# pendkit modules that load matplotlib and python-control are imported inside the functions that use them: importing
# this module does not need them (start-up).

DEFAULT_PRESET = next(iter(SERVO_PRESETS))  # the kit's own servo (RigParams())

KINDS = ("controller", "blob", "policy", "excitation")
RULE_EPISODES = len(RULE_STARTS)  # the kit's rule judges 10 episodes
MAX_EPISODES = 20
EPISODE_STEPS_RANGE = (SOLVED_TAIL_STEPS + 50, 2000)  # the rule judges the last 200 steps: room to come up first
MAX_UPLOAD_BYTES = 256 * 1024  # refused before parsing; the device itself takes at most 64 KB
EXCITATION_EPISODES, MAX_EXCITATION_EPISODES = 6, 20  # `pendkit adapt`'s most, about 35 s of the rig
# control steps of `pendkit adapt`'s excitation episode and of a loop episode (pendkit.adapt.excitation, a layer
# above: a test holds them equal)
EXCITATION_STEPS, LOOP_EXCITATION_STEPS = 12 + 78, 40 + 20
RESET_LIMIT_S = 60.0  # rig seconds a reset between episodes may take (pendkit.queue.rig_reset)
START_ALLOWANCE_S = 60.0  # rig seconds for the upload and the first status
SERVO_RANGE_SLACK_RAD = 1e-4  # a blob's float32 servo range against the rig's
OPTIONS = {"controller": {"controller", "preset", "params", "episodes", "episode_steps", "time_limit_s"},
           "blob": {"preset", "params", "episodes", "episode_steps", "time_limit_s"},
           "policy": {"policy", "episodes", "episode_steps", "time_limit_s"},
           "excitation": {"episodes", "loop_episodes", "time_limit_s"}}


def make_job(kind: str, options: dict | None, payload: bytes | None) -> tuple[dict, bytes | None,
                                                                               tuple[int, int] | None]:
    """(spec, payload, servo range) of a job, checked; `ConfigError` (one line) for anything a rig must not get."""
    if kind not in KINDS:
        raise ConfigError(f"unknown job kind {kind!r}; choose one of {', '.join(KINDS)}")
    options = dict(options or {})
    unknown = sorted(set(options) - OPTIONS[kind])
    if unknown:
        raise ConfigError(f"a {kind} job takes {', '.join(sorted(OPTIONS[kind]))}; not {', '.join(unknown)}")
    if kind != "blob" and payload is not None:
        raise ConfigError(f"a {kind} job takes no file (a blob job does)")
    if kind == "excitation":
        return _excitation(options), None, None
    if kind == "controller":
        params, servo = _params(options)
        blob = _controller_blob(options.get("controller"), params)
        spec = {"controller": options["controller"]}
    elif kind == "policy":
        blob, params, servo = _policy_blob(options.get("policy"))
        spec = {"policy": options["policy"]}
    else:
        params, servo = _params(options)
        blob, parsed = _checked_blob(payload)
        _check_servo(parsed, params, servo)
        spec = {"blob_kind": parsed.kind, "bytes": len(blob), "crc": zlib.crc32(blob)}
    spec.update(_episodes(options), kind=kind, servo=servo, params=params.to_dict(),
                control_step_s=_control_step_s(blob))
    spec["time_limit_s"] = _time_limit_s(options, default_time_limit_s(spec))
    return spec, blob, (params.servo_min_counts, params.servo_max_counts)


def submit_job(store, team: str, kind: str, options: dict | None = None, payload: bytes | None = None,
               priority: int = 0) -> int:
    """Check a job (`make_job`) and queue it for `team` with its time limit; its id."""
    spec, blob, servo_range = make_job(kind, options, payload)
    return store.submit(team, kind, spec, blob, servo_range, priority=priority, time_limit_s=spec["time_limit_s"])


def default_time_limit_s(spec: dict) -> float:
    """Rig seconds a job may take: each episode and its reset at the longest, and the upload."""
    if spec["kind"] == "excitation":
        steps = spec["episodes"] * EXCITATION_STEPS + spec["loop_episodes"] * LOOP_EXCITATION_STEPS
        episodes = spec["episodes"] + spec["loop_episodes"]
        return START_ALLOWANCE_S + steps * spec["control_step_s"] + episodes * RESET_LIMIT_S
    episode_s = spec["episode_steps"] * spec["control_step_s"]
    return START_ALLOWANCE_S + spec["episodes"] * (episode_s + RESET_LIMIT_S)


def _whole(options: dict, name: str, default: int, low: int, high: int) -> int:
    value = options.get(name, default)
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ConfigError(f"{name} must be a whole number in [{low}, {high}], got {value!r}")
    return value


def _episodes(options: dict) -> dict:
    return {"episodes": _whole(options, "episodes", RULE_EPISODES, 1, MAX_EPISODES),
            "episode_steps": _whole(options, "episode_steps", EPISODE_STEPS, *EPISODE_STEPS_RANGE)}


def _time_limit_s(options: dict, default_s: float) -> float:
    value = options.get("time_limit_s", default_s)
    if not is_finite_number(value) \
            or not 10 <= value <= 2 * default_s:
        raise ConfigError(f"time_limit_s must be in [10, {2 * default_s:.0f}] s of the rig's time for this job, "
                          f"got {value!r}")
    return float(value)


def _excitation(options: dict) -> dict:
    spec = {"kind": "excitation", "servo": None, "params": None, "control_step_s": RigParams().control_step_ms / 1000,
            "episodes": _whole(options, "episodes", EXCITATION_EPISODES, 1, MAX_EXCITATION_EPISODES),
            "loop_episodes": _whole(options, "loop_episodes", 0, 0, 10)}
    spec["time_limit_s"] = _time_limit_s(options, default_time_limit_s(spec))
    return spec


def _params(options: dict) -> tuple[RigParams, str]:
    """The rig a job is for: a servo preset, RigParams' fields, or the kit's rig; and its name."""
    preset, fields = options.get("preset"), options.get("params")
    if preset is not None and fields is not None:
        raise ConfigError("give preset or params, not both")
    if fields is not None:
        if not isinstance(fields, dict):
            raise ConfigError(f"params must be RigParams' fields as an object, got {type(fields).__name__}")
        known = set(RigParams.__dataclass_fields__)
        unknown = sorted(set(fields) - known)
        if unknown:
            raise ConfigError(f"params: unknown rig parameters {unknown[:5]}")
        try:
            params = RigParams(**fields)
        except TypeError as error:
            raise ConfigError(f"params: {error}") from None
        return params, "params"
    if preset is not None and (not isinstance(preset, str) or preset not in SERVO_PRESETS):
        raise ConfigError(f"unknown servo preset {str(preset)[:40]!r}; choose one of "
                          f"{', '.join(sorted(SERVO_PRESETS))}")
    return RigParams.preset(preset or DEFAULT_PRESET), preset or DEFAULT_PRESET


def _controller_blob(name, params: RigParams) -> bytes:
    from pendkit.deploy.swingup_design import design_swing_up

    if name not in CONTROLLER_NAMES:
        raise ConfigError(f"controller must be one of {', '.join(CONTROLLER_NAMES)}, got {str(name)[:40]!r}")
    try:
        return pack(design_swing_up(params, name))
    except BlobError as error:
        raise ConfigError(f"the {name} design for this rig: {error}") from None


def _policy_blob(name) -> tuple[bytes, RigParams, str]:
    """A shipped policy as its device blob (`pendkit export --policy`), for the servo it was trained on."""

    artifact = policy_artifact(name=name if isinstance(name, str) else repr(name))
    try:  # a learner the device does not run is refused here with the reason
        blob = pack(learned_policy_blob(artifact.spec, artifact.state, artifact.trained_rig, source=artifact.source))
    except BlobError as error:
        raise ConfigError(f"policy {name}: {error}") from None
    return blob, artifact.trained_rig, artifact.spec.preset or DEFAULT_PRESET


def _checked_blob(payload) -> tuple[bytes, object]:
    """An uploaded blob through the device's own checks (`controller_blob.parse`) and its runnable kinds."""

    if not isinstance(payload, (bytes, bytearray)) or not payload:
        raise ConfigError("a blob job needs the blob's bytes (`pendkit export ... --out FILE.pkcb`)")
    if len(payload) > MAX_UPLOAD_BYTES:
        raise ConfigError(f"the file is {len(payload)} bytes, more than the queue takes ({MAX_UPLOAD_BYTES}); "
                          "a rig takes at most 64 KB")
    try:
        parsed = parse(bytes(payload))
    except BlobError as error:
        raise ConfigError(f"the blob is refused by the device's checks: {error}") from None
    if parsed.kind not in RUNNABLE_KINDS:
        raise ConfigError(f"a {parsed.kind} blob: the device runs {', '.join(RUNNABLE_KINDS)} "
                          "(export a policy with `pendkit export --policy`, docs/on-device.md)")
    return bytes(payload), parsed


def _check_servo(parsed, params: RigParams, servo: str) -> None:
    """A swing-up carries its servo's range: it must be the job's servo's."""
    if parsed.kind != "swing-up":
        return
    blob_range_rad = parsed.scalars["servo_range_rad"]
    if abs(blob_range_rad - params.servo_range_rad) > SERVO_RANGE_SLACK_RAD:
        raise ConfigError(f"the blob was designed for a servo of +-{math.degrees(blob_range_rad):.1f} deg, the job's "
                          f"servo ({servo}) turns +-{params.servo_range_deg:.1f} deg: export it for the rig's servo "
                          "(--params RIG.json) or name the servo it was made for (preset/params)")


def _control_step_s(blob: bytes) -> float:
    parsed = parse(blob)
    return round(float(parsed.scalars["period_s"] if parsed.kind == "swing-up" else parsed.period_s), 6)
