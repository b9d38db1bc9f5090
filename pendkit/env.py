"""`pendkit/SwingUp-v0`: the one Gymnasium env, for the MuJoCo twin and (later) the real rig."""

from __future__ import annotations

import math
import os
import re
from typing import Any

import gymnasium as gym
import numpy as np

from pendkit.backend_contract import RigState, ServoCommand
from pendkit.device.logic import action_increments_counts, discrete_command
from pendkit.env_name import ENV_ID, EPISODE_STEPS  # noqa: F401 - re-exported
from pendkit.errors import ActionError, ConfigError
from pendkit.features import PAPER_FEATURES, angle_from_upright_rad, resolve_features, reward
from pendkit.rig import RigParams
from pendkit.sim.backend import STARTS, SimBackend
from pendkit.sim.fidelity import Fidelity
from pendkit.sim.render import DrawnFrames, mujoco_renderer

# pendkit modules that load matplotlib, python-control, manifold3d and paho-mqtt are imported inside the functions
# that use them: importing this module does not need them (start-up).

ACTION_MODES = ("discrete", "continuous")
FEATURE_SOURCES = ("measured", "estimated", "estimated+measured")
OBSERVED_SOURCES = ("estimated", "estimated+measured")  # the feature sources that run an observer
RIG_PROTOCOLS = {"v1": 1, "v2": 2}  # v1: the authors' firmware; v2: the kit's (docs/protocol.md)
RIG_OPTIONS = ("username", "password", "tls_ca", "observation_timeout_s", "reset_stop_s", "settle",
               "connect_timeout_s", "network_latency_ms")
RIG_ID = re.compile(r"[A-Za-z0-9_-]{1,32}")  # it becomes part of MQTT topics: no '/', '+', '#' or spaces
DISCRETE_ACTION_NAMES = ("stop", "left slow", "left fast", "right slow", "right fast")
_RANGE_TOLERANCE = 1e-6  # float32 policies may land a hair outside [-1, 1]



def _rig_or_bank(value) -> bool:
    return isinstance(value, RigParams) or (isinstance(value, (list, tuple)) and len(value) > 0
                                            and all(isinstance(v, RigParams) for v in value))

class SwingUpEnv(gym.Env):
    """Swing up and balance a rotary (Furuta) pendulum driven by a hobby position servo.

    ## Description
    A servo turns a 400 mm arm in the horizontal plane; a 400 mm dowel hangs from an absolute encoder at
    the arm's end. The agent moves the servo's *target position*; the servo slews towards it at its rated
    speed. The goal is to bring the pendulum upright and keep it there. The same env drives the MuJoCo
    twin (`backend="sim"`) and, through the rig link, the real rig.

    ## Action Space
    `action_mode="discrete"`: `Discrete(5)`; the servo target moves on every 10 ms acting tick until the
    next action (or the arm's limit):

    | action | meaning    | target change per acting tick (D645MW) |
    |--------|------------|----------------------------------------|
    | 0      | stop       | 0                                      |
    | 1      | left slow  | -2 counts (-1.2 deg)                   |
    | 2      | left fast  | -4 counts (-2.4 deg)                   |
    | 3      | right slow | +2 counts                              |
    | 4      | right fast | +4 counts                              |

    `action_mode="continuous"`: `Box(-1, 1, (1,))`, the target from leftmost (-1, -90 deg) to rightmost
    (+1, +90 deg), passed through the filter `a_t = c*a_(t-1) + (1-c)*u_t` (c = 0.85) before it is sent.

    ## Observation Space
    `Box` of float32, features chosen with `observation=` (default: the paper's seven):

    | feature               | unit    | range        | meaning                                          |
    |-----------------------|---------|--------------|--------------------------------------------------|
    | pendulum_angle        | rad     | [-pi, pi)    | from upright (0 = upright, -pi = hanging)        |
    | arm_angle             | rad     | [-pi/2, pi/2]| arm angle (servo command on the realistic twin)  |
    | pendulum_velocity     | rad/s   | unbounded    | pendulum rate                                    |
    | pendulum_acceleration | rad/s^2 | unbounded    | pendulum angular acceleration                    |
    | arm_velocity          | rad/s   | unbounded    | arm rate                                         |
    | time_since_action     | s       | [0, inf)     | from sending the last action to this observation |
    | observation_age       | s       | [0, inf)     | from receiving the observation to using it       |

    Also available: `pendulum_cos`, `pendulum_sin`, `servo_target`.

    ## Rewards
    `-theta^2 - 0.5 * omega^2` per step, theta from upright in rad, omega in rev/s (the paper's reward),
    from the observed state. 0 is upright and still; hanging still is about -9.87.

    ## Starting State
    `start="random"` (default): pendulum angle uniform in +-3.01 rad from hanging, rate in +-2.01 rad/s, arm
    at rest within half its range (the authors' reset). `"rest"`: hanging still, arm centred.
    `"upright"`: within 0.05 rad of upright, still (for balance experiments). `reset(options=...)` may
    override `start` and set `arm_angle_rad`, `pendulum_angle_rad` (from the bottom) and
    `pendulum_velocity_rad_s` exactly.

    ## Episode End
    Never terminates; truncates after `max_episode_steps` (500) steps, about 30 s at 60 ms a step
    (`pendkit.make(max_episode_steps=...)` sets the registered `TimeLimit`; `None` on the class: no limit).
    Readings beyond a feature's range (the arm overshooting the servo's end stop) are clipped to it and
    `info["observation_clipped"]` says so, so observations always lie in `observation_space`.

    ## Arguments
    backend ("sim"), action_mode ("discrete" | "continuous"), fidelity ("ideal" | "paper-delayed" |
    "realistic" | a `Fidelity`), observation (feature names or "paper"), start, params (`RigParams`),
    filter_coefficient (default `params.filter_coefficient`), max_episode_steps, render_mode ("rgb_array"),
    log_dir (realistic twin or rig: every message of each episode to `log_dir/episode-NNNN.jsonl`);
    features ("measured": the readings as they arrive; "estimated": a model-based observer's estimate of the
    present state from the readings and the actions sent, `pendkit.control.estimated_state`; "estimated+measured":
    the estimate, then the readings, so a policy can see where the observer's model and the rig part);
    observer_params (with features="estimated": the rig the observer is designed for, or a tuple of rigs for
    `pendkit.control.observer_bank`, fixed through `set_rig`; default `params`, followed through `set_rig`. A
    policy meant for rigs it does not know is trained and judged with the nominal rig's observer);
    with backend="rig": rig ("r01"), broker (URL, default mqtt://127.0.0.1:1883), rig_options (username,
    password, tls_ca, observation_timeout_s, reset_stop_s, settle, connect_timeout_s, network_latency_ms),
    protocol ("v2", or "v1" for a rig
    flashed with the authors' firmware: single-letter commands, no heartbeat, no device watchdog).

    ## Version History
    v0: first release.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 16}

    def __init__(self, backend: str = "sim", action_mode: str = "discrete", fidelity: str | Fidelity = "ideal",
                 observation: tuple[str, ...] | str = PAPER_FEATURES, start: str = "random",
                 params: RigParams | None = None, filter_coefficient: float | None = None,
                 max_episode_steps: int | None = EPISODE_STEPS, render_mode: str | None = None,
                 log_dir: str | None = None, rig: str = "r01", broker: str | None = None,
                 rig_options: dict[str, Any] | None = None, features: str = "measured",
                 protocol: str = "v2", observer_params: RigParams | tuple[RigParams, ...] | None = None) -> None:
        if action_mode not in ACTION_MODES:
            raise ConfigError(f"action_mode must be one of {ACTION_MODES}, got {action_mode!r}")
        if start not in STARTS:
            raise ConfigError(f"start must be one of {STARTS}, got {start!r}")
        if protocol not in RIG_PROTOCOLS:
            raise ConfigError(f"protocol must be one of {tuple(RIG_PROTOCOLS)}, got {protocol!r}")
        if protocol != "v2" and backend != "rig":
            raise ConfigError("protocol='v1' is for backend='rig' (a rig flashed with the authors' firmware)")
        if features not in FEATURE_SOURCES:
            raise ConfigError(f"features must be one of {FEATURE_SOURCES}, got {features!r}")
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ConfigError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        if max_episode_steps is not None and not (isinstance(max_episode_steps, (int, np.integer))
                                                  and not isinstance(max_episode_steps, bool)
                                                  and max_episode_steps >= 1):
            raise ConfigError(f"max_episode_steps must be a positive whole number or None, got {max_episode_steps!r}")
        if params is not None and not isinstance(params, RigParams):
            raise ConfigError(f"params must be a pendkit.RigParams (e.g. RigParams.preset('mks-x5-hbl550')), "
                              f"got {type(params).__name__} {params!r}")
        self.params = params if params is not None else RigParams()
        if observer_params is not None and (features not in OBSERVED_SOURCES or not _rig_or_bank(observer_params)):
            raise ConfigError("observer_params is a pendkit.RigParams (or a bank of them) for features='estimated', "
                              f"got {type(observer_params).__name__} with features={features!r}")
        observer_params = tuple(observer_params) if isinstance(observer_params, (list, tuple)) else observer_params
        if filter_coefficient is not None and (isinstance(filter_coefficient, bool)
                                               or not isinstance(filter_coefficient, (int, float, np.number))):
            raise ConfigError(f"filter_coefficient must be a number in [0, 1), got {filter_coefficient!r}")
        self.filter_coefficient = self.params.filter_coefficient if filter_coefficient is None \
            else float(filter_coefficient)
        if not 0.0 <= self.filter_coefficient < 1.0:
            raise ConfigError(f"filter_coefficient must be in [0, 1), got {self.filter_coefficient}")
        if log_dir is not None and not isinstance(log_dir, (str, os.PathLike)):
            raise ConfigError(f"log_dir must be a folder path, got {type(log_dir).__name__} {log_dir!r}")
        if rig_options and backend != "rig":
            raise ConfigError(f"rig_options are for backend='rig', got {sorted(rig_options)} with backend={backend!r}")
        unknown = set(rig_options or {}) - set(RIG_OPTIONS)
        if unknown:
            raise ConfigError(f"unknown rig_options {sorted(unknown)}; accepted: {', '.join(RIG_OPTIONS)}")
        if backend == "rig" and not (isinstance(rig, str) and RIG_ID.fullmatch(rig)):
            raise ConfigError(f"rig must be a rig id of letters, digits, '-' or '_' (1-32, e.g. 'r01'), got {rig!r}")
        rig_options = {**(rig_options or {}), "protocol": RIG_PROTOCOLS[protocol]} if backend == "rig" else {}
        self.backend = _make_backend(backend, self.params, fidelity, log_dir, rig, broker, rig_options)
        self.action_mode = action_mode
        self.features = resolve_features(observation)
        self._readers = tuple(feature.read for feature in self.features)
        self.start = start
        self.max_episode_steps = max_episode_steps
        self.render_mode = render_mode
        self.dt = self.backend.nominal_step_s
        self.metadata = {**self.metadata, "render_fps": max(1, round(1 / self.dt))}
        self._set_increments()
        if action_mode == "discrete":
            self.action_space = gym.spaces.Discrete(len(self._increments))
        else:
            self.action_space = gym.spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)
        shown = self.features * (2 if features == "estimated+measured" else 1)  # the estimate, then the readings
        self.observation_space = gym.spaces.Box(np.array([f.low for f in shown], dtype=np.float32),
                                                np.array([f.high for f in shown], dtype=np.float32), dtype=np.float32)
        self._bounded = tuple((k, float(self.observation_space.low[k]), float(self.observation_space.high[k]))
                              for k in range(len(shown)))
        self._state: RigState | None = None
        self._shown: RigState | None = None  # what the observation is made of: measured, or estimated
        self._estimator = None
        self.feature_source = features  # "measured" or "estimated": what a learner built for this env expects
        self._observer_design = None  # (params, timing; None: each backend's) kept through set_rig
        if observer_params is not None:
            self._observer_design = (observer_params, self.timing)
        if features in OBSERVED_SOURCES:
            self._estimator = self._new_estimator()
        self._filtered_unit = 0.0
        self._steps = 0
        self._clipped = False
        self._gl_renderer, self._gl_data = None, None
        self._drawn_frames = None

    def _set_increments(self) -> None:
        self._increments = action_increments_counts(self.params)
        self._discrete_commands = tuple(discrete_command(k, self.params) for k in range(len(self._increments)))

    def _new_estimator(self):
        """The observer's feed, designed for this step and the backend's own delays (or the pinned design)."""
        from pendkit.control.observer_bank import observer_feed

        params, timing = self._observer_design or (self.params, None)
        return observer_feed(params, self.dt, timing or self.timing)

    @property
    def timing(self):
        """What the backend tells controllers about time (`BackendTiming`): the step, the command's and the
        reading's delays, and whether the readings are the firmware's (worth an observer)."""
        return self.backend.timing

    @property
    def observes(self) -> bool:
        """True when an observer feeds the observation (features "estimated" or "estimated+measured")."""
        return self.feature_source in OBSERVED_SOURCES

    @property
    def observer_pinned(self) -> bool:
        """True when the observer keeps its design through `set_rig` (`observer_params` or `pin_observer`)."""
        return self._observer_design is not None

    def pin_observer(self, params: RigParams | tuple[RigParams, ...] | None = None, keep_timing: bool = True) -> None:
        """Keep the observer designed for `params` (default: the rigs it is pinned to, else the present one)
        through every later `set_rig`: training over rigs the observer does not know; with the present backend's
        timing, or (`keep_timing` False) each backend's own delays, as a device designs its observers for its own."""
        params = params or (self._observer_design or (self.params,))[0]
        self._observer_design = (params, self.timing if keep_timing else None)
        if self._estimator is not None:
            self._estimator = self._new_estimator()

    def set_rig(self, params: RigParams, fidelity: str | Fidelity | None = None) -> None:
        """Swap the twin for one with other parameters (domain randomisation), from the next `reset()` on.
        Spaces and the control step stay as they are; only a sim backend can be swapped."""
        if not isinstance(self.backend, SimBackend):
            raise ConfigError("set_rig needs the sim backend: a real rig's parameters are what they are")
        if params.control_step_ms != self.params.control_step_ms:
            raise ConfigError(f"set_rig keeps the control step: {self.params.control_step_ms} ms, "
                              f"got {params.control_step_ms} ms")
        fidelity = self.backend.fidelity if fidelity is None else fidelity
        self.backend.close()
        self.backend = SimBackend(params, fidelity, self.backend.log_dir)
        self.params = params
        self._close_renderers()  # drawn for the old rig's dimensions
        self._set_increments()
        if self._estimator is not None:
            self._estimator = self._new_estimator()
        self._state = None

    # --- Gymnasium API ---
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        options = dict(options or {})
        start = options.pop("start", self.start)
        self._state = self.backend.reset(self.np_random, start, options)
        self._shown = self._estimator.reset(self._state) if self._estimator is not None else self._state
        self._filtered_unit = self._state.servo_target_rad / self.params.servo_range_rad
        self._steps = 0
        return self._observation(), self._info()

    def step(self, action):
        if self._state is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        command = self._command_for(action)  # validates; raises before any state changes
        if command.mode == "continuous":
            self._filtered_unit = command.target_unit
        self._state = self.backend.step(command)
        self._shown = self._estimator.update(command, self._state) if self._estimator is not None else self._state
        self._steps += 1
        truncated = self.max_episode_steps is not None and self._steps >= self.max_episode_steps
        return self._observation(), reward(self._state), False, truncated, self._info()

    def render(self):
        if self.render_mode != "rgb_array" or self._state is None:
            return None
        if isinstance(self.backend, SimBackend):
            if self._gl_renderer is None and self._drawn_frames is None:
                self._start_gl_renderer()
            if self._gl_renderer is not None:
                import mujoco

                self._gl_data.qpos[:] = self.backend.data.qpos
                # kinematics alone leaves the cameras and lights at the origin: the scene needs both
                mujoco.mj_kinematics(self._gl_renderer.model, self._gl_data)
                mujoco.mj_camlight(self._gl_renderer.model, self._gl_data)
                self._gl_renderer.update_scene(self._gl_data, camera="front")
                return self._gl_renderer.render()
        if self._drawn_frames is None:
            self._drawn_frames = DrawnFrames(self.params)
        true = self.backend.true_state() if isinstance(self.backend, SimBackend) else None
        arm = true["arm_angle_rad"] if true else self._state.arm_angle_rad
        pendulum = true["pendulum_angle_rad"] if true else self._state.pendulum_angle_rad
        return self._drawn_frames.frame(arm, pendulum)

    def _start_gl_renderer(self) -> None:
        """MuJoCo's renderer on the twin's drawn model (printed parts as meshes), or None without GL."""
        import mujoco

        from pendkit.cad.twin_meshes import visual_twin_model

        model = visual_twin_model(self.params)
        self._gl_renderer = mujoco_renderer(model)
        self._gl_data = mujoco.MjData(model) if self._gl_renderer is not None else None

    def _close_renderers(self) -> None:
        if self._gl_renderer is not None:
            self._gl_renderer.close()
        self._gl_renderer, self._gl_data, self._drawn_frames = None, None, None

    def close(self) -> None:
        self._close_renderers()
        self.backend.close()

    # --- action mapping ---
    def _command_for(self, action) -> ServoCommand:
        if self.action_mode == "discrete":
            return self._discrete_commands[self._discrete_index(action)]
        value = _continuous_value(action)
        c = self.filter_coefficient
        return ServoCommand("continuous", target_unit=c * self._filtered_unit + (1 - c) * value)

    def _discrete_index(self, action) -> int:
        n = len(self._increments)
        if type(action) is int and 0 <= action < n:  # the common case, ahead of the checks below
            return action
        array = np.asarray(action) if isinstance(action, (np.ndarray, np.generic)) else None
        if isinstance(action, (bool, np.bool_)) or (array is not None and array.dtype == bool):
            raise ActionError(f"Discrete action must be an integer in [0, {n - 1}], got a boolean {action!r}")
        if isinstance(action, int):
            index = action
        elif array is not None and np.issubdtype(array.dtype, np.integer) and array.size == 1 \
                and array.ndim <= 1:
            index = int(array.reshape(()))
        else:
            kind = f"array of shape {array.shape} and dtype {array.dtype}" if array is not None else \
                f"{type(action).__name__} {action!r}"
            raise ActionError(f"Discrete action must be an integer in [0, {n - 1}], got {kind}")
        if not 0 <= index < n:
            raise ActionError(f"Discrete action out of range: expected 0..{n - 1} "
                              f"({', '.join(DISCRETE_ACTION_NAMES)}), got {index}")
        return index

    # --- observation ---
    def _observation(self) -> np.ndarray:
        shown, readers = self._shown, self._readers
        values = [read(shown) for read in readers]
        if self.feature_source == "estimated+measured":
            values += [read(self._state) for read in readers]
        self._clipped = False
        for index, low, high in self._bounded:  # plain floats: cheaper than numpy on 7 values
            value = values[index]
            if not low <= value <= high:
                if value != value:  # NaN: a backend bug (decoding rejects NaN readings)
                    name = self.features[index % len(self.features)].name
                    raise FloatingPointError(f"the observation's {name} is NaN")
                values[index] = low if value < low else high
                self._clipped = True
        return np.array(values, dtype=np.float32)

    def _info(self) -> dict[str, Any]:
        state = self._state
        info = {
            "angle_from_upright_rad": angle_from_upright_rad(state),
            "observation_age_s": state.observation_age_s,
            "time_since_action_s": state.time_since_action_s,
            "servo_target_rad": state.servo_target_rad,
            "safety_flags": state.safety_flags,
            "observation_clipped": self._clipped,  # a reading beyond its feature's range (e.g. arm overshoot)
            "state": state,
        }
        if isinstance(self.backend, SimBackend):
            info["true_state"] = self.backend.true_state()
        return info


def _continuous_value(action) -> float:
    try:
        array = np.asarray(action)
    except Exception:
        raise ActionError(f"Continuous action must be a float array of shape (1,), got {action!r}") from None
    if array.dtype.kind not in "fiu" or array.dtype == bool:
        raise ActionError(f"Continuous action must be numeric with shape (1,), got dtype {array.dtype}")
    if array.shape not in ((1,), ()):
        raise ActionError(f"Action shape mismatch: expected (1,), got {array.shape}")
    value = float(array.reshape(()))
    if not math.isfinite(value):
        raise ActionError(f"Continuous action must be finite, got {value}")
    if abs(value) > 1.0 + _RANGE_TOLERANCE:
        raise ActionError(f"Continuous action out of range: expected [-1, 1], got {value}")
    return max(-1.0, min(1.0, value))


def _make_backend(backend, params: RigParams, fidelity, log_dir, rig: str, broker: str | None, rig_options: dict):
    if backend == "sim":
        if broker is not None or rig_options:
            raise ConfigError("broker= and rig_options= are for backend='rig'; the twin (backend='sim') takes neither")
        return SimBackend(params, fidelity, log_dir)
    if backend == "rig":
        from pendkit.link.rig_backend import RigBackend

        return RigBackend(params, rig=rig, broker=broker, log_dir=log_dir, **rig_options)
    if hasattr(backend, "reset") and hasattr(backend, "step") and hasattr(backend, "nominal_step_s"):
        return backend  # a custom backend object
    raise ConfigError(f"backend must be 'sim' or 'rig', got {backend!r}")
