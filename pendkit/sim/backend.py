"""`SimBackend`: the MuJoCo twin turning `ServoCommand`s into `RigState`s at a chosen fidelity."""

from __future__ import annotations

import math
from collections import deque
from pathlib import Path
from typing import Literal

import mujoco
import numpy as np

from pendkit.backend_contract import BackendTiming, RigState, ServoCommand
from pendkit.checks import is_finite_number
from pendkit.device.commands import command_body, frame_command
from pendkit.device.observation import McuObservation, observation_to_state
from pendkit.device.protocol import format_observation_v1
from pendkit.errors import ConfigError
from pendkit.network import NetworkPath
from pendkit.rig import RigParams
from pendkit.sim.fidelity import Fidelity, resolve_fidelity
from pendkit.sim.model import ARM_JOINT, PENDULUM_JOINT, build_model
from pendkit.sim.twin_device import TwinDevice
from pendkit.telemetry.log import EpisodeLog

Start = Literal["random", "rest", "upright"]
STARTS = ("random", "rest", "upright")
# The authors' reset: joint positions uniform in +-3.01 rad and velocities in +-2.01 rad/s. Our arm is
# limited to the servo's range, so it starts at rest within half of it instead.
RANDOM_PENDULUM_ANGLE_RAD = 3.01
RANDOM_PENDULUM_VELOCITY_RAD_S = 2.01
RANDOM_ARM_FRACTION_OF_RANGE = 0.5
UPRIGHT_PERTURBATION_RAD = 0.05
MAX_INITIAL_RATE_RAD_S = 40.0  # about 6 rev/s: beyond any swing-up, far beyond the firmware's over-spin stop
TWIN_OBS_TOPIC, TWIN_ACT_TOPIC = "pendulum-r/obs/twin", "pendulum-r/act/twin"
# reset(options=...) may set these; the pendulum angle is from the bottom (pi = upright).
INITIAL_STATE_KEYS = ("arm_angle_rad", "pendulum_angle_rad", "pendulum_velocity_rad_s")


class SimBackend:
    """The twin. `reset(rng, start)` and `step(command)` return what the host would observe."""

    def __init__(self, params: RigParams | None = None, fidelity: str | Fidelity = "ideal",
                 log_dir: str | Path | None = None) -> None:
        self.params = params or RigParams()
        self.log_dir = Path(log_dir) if log_dir is not None else None
        if self.log_dir is not None and not resolve_fidelity(fidelity).mcu_pipeline:
            raise ConfigError("log_dir needs a fidelity with the MCU pipeline (e.g. 'realistic'): only it "
                              "exchanges messages")
        self._log: EpisodeLog | None = None
        self._episodes = 0
        self.fidelity = resolve_fidelity(fidelity)
        self.model = build_model(self.params)
        self.data = mujoco.MjData(self.model)
        # MjData hands out a new array view on every attribute read: the ones read on every step, taken once
        self._qpos, self._qvel, self._qacc = self.data.qpos, self.data.qvel, self.data.qacc
        self._arm_q = self.model.joint(ARM_JOINT).qposadr[0]
        self._pend_q = self.model.joint(PENDULUM_JOINT).qposadr[0]
        self._arm_v = self.model.joint(ARM_JOINT).dofadr[0]
        self._pend_v = self.model.joint(PENDULUM_JOINT).dofadr[0]
        self.substeps = self.fidelity.substeps_per_step or self.params.frame_skip
        self.physics_step_s = self.params.physics_step_ms / 1000.0
        self._rate_per_increment = (self.params.servo_rad_per_count * 1000.0 / self.params.acting_period_ms)
        self._rng = np.random.default_rng(0)
        self._network = NetworkPath(self.fidelity.network, self._rng) if self.fidelity.mcu_pipeline else None
        self._device = (TwinDevice(self.params, self.model, self.data, self._pend_q,
                                   self.fidelity.encoder_mount_offset_counts,
                                   residual_offset_counts=self.fidelity.encoder_residual_offset_counts)
                        if self.fidelity.mcu_pipeline else None)
        self._tick = 0

    @property
    def ticks(self) -> int:
        """Physics ticks since the last reset."""
        return self._device.tick if self._device is not None else self._tick

    def __getstate__(self) -> dict:
        """Pickled without the cached views (a copy's views must be of its own MjData)."""
        return {k: v for k, v in self.__dict__.items() if k not in ("_qpos", "_qvel", "_qacc")}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._qpos, self._qvel, self._qacc = self.data.qpos, self.data.qvel, self.data.qacc

    @property
    def nominal_step_s(self) -> float:
        """Mean duration of one env step (the paper-delayed preset adds 0..max substeps)."""
        return self.fidelity.nominal_step_s(self.params)

    @property
    def timing(self) -> BackendTiming:
        return self.fidelity.timing(self.params)

    # --- reset ---
    def reset(self, rng: np.random.Generator, start: Start = "random",
              initial: dict[str, float] | None = None) -> RigState:
        """Start as `start` says, then apply any of `INITIAL_STATE_KEYS` given in `initial`."""
        if start not in STARTS:
            raise ConfigError(f"start must be one of {STARTS}, got {start!r}")
        initial = dict(initial or {})
        unknown = set(initial) - set(INITIAL_STATE_KEYS)
        if unknown:
            raise ConfigError(f"unknown initial state keys {sorted(unknown)}; expected some of {INITIAL_STATE_KEYS}")
        for key, value in initial.items():
            if not is_finite_number(value):
                raise ConfigError(f"initial {key} must be a finite number, got {value!r}")
        rate = initial.get("pendulum_velocity_rad_s", 0.0)
        if abs(rate) > MAX_INITIAL_RATE_RAD_S:
            raise ConfigError(f"initial pendulum_velocity_rad_s must be within +-{MAX_INITIAL_RATE_RAD_S} rad/s (a "
                              f"fast hand spin; beyond it the twin's physics is not the rig's), got {rate}")
        self._rng = rng
        mujoco.mj_resetData(self.model, self.data)
        arm, pendulum, pendulum_velocity = 0.0, 0.0, 0.0
        if start == "random":
            arm = rng.uniform(-1, 1) * RANDOM_ARM_FRACTION_OF_RANGE * self.params.servo_range_rad
            pendulum = rng.uniform(-RANDOM_PENDULUM_ANGLE_RAD, RANDOM_PENDULUM_ANGLE_RAD)
            pendulum_velocity = rng.uniform(-RANDOM_PENDULUM_VELOCITY_RAD_S, RANDOM_PENDULUM_VELOCITY_RAD_S)
        elif start == "upright":
            pendulum = math.pi + rng.uniform(-UPRIGHT_PERTURBATION_RAD, UPRIGHT_PERTURBATION_RAD)
        arm = initial.get("arm_angle_rad", arm)
        pendulum = initial.get("pendulum_angle_rad", pendulum)
        pendulum_velocity = initial.get("pendulum_velocity_rad_s", pendulum_velocity)
        if abs(arm) > self.params.servo_range_rad:
            raise ConfigError(f"initial arm_angle_rad must be within +-{self.params.servo_range_rad:.3f}, got {arm}")
        if self._device is not None:
            servo_counts = self.params.servo_rad_to_counts(arm)
            arm = self.params.servo_counts_to_rad(servo_counts)
        self.data.qpos[self._arm_q] = arm
        self.data.qpos[self._pend_q] = pendulum
        self.data.qvel[self._pend_v] = pendulum_velocity
        self.data.act[0] = arm
        mujoco.mj_forward(self.model, self.data)
        self._tick = 0
        if self._device is None:
            return self._observe_true(0.0, 0.0)
        self._device.reset(servo_counts)
        if self.log_dir is not None:
            if self._log is not None:
                self._log.close()
            self._episodes += 1
            self._log = EpisodeLog(self.log_dir / f"episode-{self._episodes:04d}.jsonl")
        self._in_flight: deque[tuple[float, McuObservation]] = deque()
        self._network.restart(rng)
        self._newest: tuple[float, McuObservation] | None = None
        # Warm up so that an observation has arrived and the estimator has history.
        while self._newest is None or self._device.tick < self.substeps:
            self._run_mcu_substeps(1)
        return self._observe_mcu(time_since_action_s=0.0)

    # --- step ---
    def step(self, command: ServoCommand) -> RigState:
        if self._device is not None:
            return self._step_mcu(command)
        data = self.data
        if command.mode == "continuous":
            data.ctrl[0] = 0.0
            data.act[0] = command.target_unit * self.params.servo_range_rad
        else:
            data.ctrl[0] = command.increment_counts * self._rate_per_increment
        mujoco.mj_step(self.model, data, self.substeps)
        self._tick += self.substeps
        state = self._observe_true(0.0, self.substeps * self.physics_step_s)
        extra = self.fidelity.post_observation_substeps_max
        if extra:
            more = int(self._rng.integers(0, extra + 1))
            if more:
                mujoco.mj_step(self.model, data, more)
                self._tick += more
                state = state._replace(observation_age_s=more * self.physics_step_s)
        return state

    def _observe_true(self, age_s: float, since_action_s: float) -> RigState:
        qpos, qvel, qacc = self._qpos.tolist(), self._qvel.tolist(), self._qacc.tolist()
        return RigState(
            time_s=self.data.time,
            pendulum_angle_rad=qpos[self._pend_q] % (2 * math.pi),
            pendulum_velocity_rad_s=qvel[self._pend_v],
            pendulum_acceleration_rad_s2=qacc[self._pend_v],
            arm_angle_rad=qpos[self._arm_q],
            arm_velocity_rad_s=qvel[self._arm_v],
            servo_target_rad=self.data.act.item(0),
            observation_age_s=age_s,
            time_since_action_s=since_action_s,
        )

    # --- the MCU pipeline (realistic) ---
    def _step_mcu(self, command: ServoCommand) -> RigState:
        # The host's own command path: the device parses what a rig receives. Bare v1 bodies: nothing in the
        # twin reads the v2 echo, and the parser's cache then serves the few distinct commands.
        return self.step_with_message(frame_command(command_body(command, self.params), 1))

    def send(self, payload: str | bytes) -> None:
        """A message from the host to the device through the network (its latency and losses): a command's
        text, or an upload chunk (`pendkit.device.onboard`). Realistic fidelity only."""
        if self._device is None:
            raise ConfigError("only a fidelity with the MCU pipeline (e.g. 'realistic') has a device to send to")
        now_ms = self._device.now_ms
        arrival = self._network.command_arrival_ms(now_ms)
        if arrival is not None:
            self._device.deliver(arrival, payload)
        if self._log is not None and isinstance(payload, str):
            self._log.write(now_ms / 1000, "tx", TWIN_ACT_TOPIC, payload)

    def step_with_message(self, payload: str | bytes) -> RigState:
        """One env step after sending `payload` (e.g. the heartbeat `h` while the device runs its own
        controller); the observation as the host receives it."""
        self.send(payload)
        self._run_mcu_substeps(self.substeps)
        return self._observe_mcu(time_since_action_s=self.substeps * self.physics_step_s)

    @property
    def episode_log(self) -> EpisodeLog | None:
        """This episode's message log (None without `log_dir`)."""
        return self._log

    @property
    def device(self) -> TwinDevice | None:
        """The twin's device (its status is what a rig would publish)."""
        return self._device

    def _run_mcu_substeps(self, count: int) -> None:
        device, in_flight = self._device, self._in_flight
        device.run(count, self._in_flight_append)
        now_ms = device.now_ms
        while in_flight and in_flight[0][0] <= now_ms:
            self._newest = in_flight.popleft()
            if self._log is not None:
                self._log.write(self._newest[0] / 1000, "rx", TWIN_OBS_TOPIC, format_observation_v1(self._newest[1]))

    def _in_flight_append(self, now_ms: float, observation: McuObservation) -> None:
        delivery = self._network.observation_delivery_ms(now_ms)
        if delivery is not None:
            self._in_flight.append((delivery, observation))

    def _observe_mcu(self, time_since_action_s: float) -> RigState:
        delivered_ms, observation = self._newest
        return observation_to_state(observation, self.params, (self._device.now_ms - delivered_ms) / 1000.0,
                                    time_since_action_s, self._device.mcu.servo_counts)

    def push_pendulum(self, rate_change_rad_s: float) -> None:
        """Change the pendulum's rate at once, as a hand's tap on the dowel does (`pendkit.sim.pushes`)."""
        if not math.isfinite(rate_change_rad_s):
            raise ConfigError(f"a push must be a finite rate change, got {rate_change_rad_s!r}")
        self.data.qvel[self._pend_v] += rate_change_rad_s
        mujoco.mj_forward(self.model, self.data)

    # --- inspection ---
    def true_state(self) -> dict[str, float]:
        """The twin's exact joint state (for info and tests; a real rig has no such thing)."""
        qpos, qvel = self._qpos.tolist(), self._qvel.tolist()
        return {
            "arm_angle_rad": qpos[self._arm_q],
            "arm_velocity_rad_s": qvel[self._arm_v],
            "pendulum_angle_rad": qpos[self._pend_q],
            "pendulum_velocity_rad_s": qvel[self._pend_v],
            "time_s": self.data.time,
        }

    def close(self) -> None:
        """Close the episode log, if any."""
        if self._log is not None:
            self._log.close()
            self._log = None

