"""`SimBackend`: the MuJoCo twin turning `ServoCommand`s into `RigState`s at a chosen fidelity."""

from __future__ import annotations

import math
from collections import deque
from typing import Literal

import mujoco
import numpy as np

from pendkit.encoder import counts_to_rad, rad_to_counts
from pendkit.errors import ConfigError
from pendkit.mcu import McuLogic, McuObservation, calibrate_position
from pendkit.rig import RigParams
from pendkit.sim.fidelity import Fidelity, resolve_fidelity
from pendkit.sim.model import ARM_JOINT, PENDULUM_JOINT, build_model
from pendkit.state import STOP, RigState, ServoCommand

Start = Literal["random", "rest", "upright"]
STARTS = ("random", "rest", "upright")
# The authors' reset: joint positions uniform in +-3.01 rad and velocities in +-2.01 rad/s. Our arm is
# limited to the servo's range, so it starts at rest within half of it instead.
RANDOM_PENDULUM_ANGLE_RAD = 3.01
RANDOM_PENDULUM_VELOCITY_RAD_S = 2.01
RANDOM_ARM_FRACTION_OF_RANGE = 0.5
UPRIGHT_PERTURBATION_RAD = 0.05


class SimBackend:
    """The twin. `reset(rng, start)` and `step(command)` return what the host would observe."""

    def __init__(self, params: RigParams | None = None, fidelity: str | Fidelity = "ideal") -> None:
        self.params = params or RigParams()
        self.fidelity = resolve_fidelity(fidelity)
        self.model = build_model(self.params)
        self.data = mujoco.MjData(self.model)
        self._arm_q = self.model.joint(ARM_JOINT).qposadr[0]
        self._pend_q = self.model.joint(PENDULUM_JOINT).qposadr[0]
        self._arm_v = self.model.joint(ARM_JOINT).dofadr[0]
        self._pend_v = self.model.joint(PENDULUM_JOINT).dofadr[0]
        self.substeps = self.fidelity.substeps_per_step or self.params.frame_skip
        self.physics_step_s = self.params.physics_step_ms / 1000.0
        self._rate_per_increment = (self.params.servo_rad_per_count * 1000.0 / self.params.acting_period_ms)
        self._rng = np.random.default_rng(0)
        self._mcu = McuLogic(self.params) if self.fidelity.mcu_pipeline else None
        self._tick = 0

    @property
    def nominal_step_s(self) -> float:
        """Mean duration of one env step (the paper-delayed preset adds 0..max substeps)."""
        extra = self.fidelity.post_observation_substeps_max / 2
        return (self.substeps + extra) * self.physics_step_s

    # --- reset ---
    def reset(self, rng: np.random.Generator, start: Start = "random") -> RigState:
        if start not in STARTS:
            raise ConfigError(f"start must be one of {STARTS}, got {start!r}")
        self._rng = rng
        mujoco.mj_resetData(self.model, self.data)
        arm, pendulum, pendulum_velocity = 0.0, 0.0, 0.0
        if start == "random":
            arm = rng.uniform(-1, 1) * RANDOM_ARM_FRACTION_OF_RANGE * self.params.servo_range_rad
            pendulum = rng.uniform(-RANDOM_PENDULUM_ANGLE_RAD, RANDOM_PENDULUM_ANGLE_RAD)
            pendulum_velocity = rng.uniform(-RANDOM_PENDULUM_VELOCITY_RAD_S, RANDOM_PENDULUM_VELOCITY_RAD_S)
        elif start == "upright":
            pendulum = math.pi + rng.uniform(-UPRIGHT_PERTURBATION_RAD, UPRIGHT_PERTURBATION_RAD)
        if self._mcu is not None:
            servo_counts = self.params.servo_rad_to_counts(arm)
            arm = self.params.servo_counts_to_rad(servo_counts)
        self.data.qpos[self._arm_q] = arm
        self.data.qpos[self._pend_q] = pendulum
        self.data.qvel[self._pend_v] = pendulum_velocity
        self.data.act[0] = arm
        mujoco.mj_forward(self.model, self.data)
        self._tick = 0
        if self._mcu is None:
            return self._observe_true(0.0, 0.0)
        self._mcu.reset(servo_counts, 0)
        self._in_flight: deque[tuple[float, McuObservation]] = deque()
        self._commands: deque[tuple[float, ServoCommand]] = deque()
        self._last_delivery_ms = self._last_command_arrival_ms = 0.0
        self._newest: tuple[float, McuObservation] | None = None
        # Warm up so that an observation has arrived and the estimator has history.
        while self._newest is None or self._tick < self.substeps:
            self._run_mcu_substeps(1)
        return self._observe_mcu(time_since_action_s=0.0)

    # --- step ---
    def step(self, command: ServoCommand) -> RigState:
        if self._mcu is not None:
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
                state = _with_age(state, more * self.physics_step_s)
        return state

    def _observe_true(self, age_s: float, since_action_s: float) -> RigState:
        qpos, qvel, qacc = self.data.qpos, self.data.qvel, self.data.qacc
        return RigState(
            time_s=self.data.time,
            pendulum_angle_rad=float(qpos[self._pend_q]) % (2 * math.pi),
            pendulum_velocity_rad_s=float(qvel[self._pend_v]),
            pendulum_acceleration_rad_s2=float(qacc[self._pend_v]),
            arm_angle_rad=float(qpos[self._arm_q]),
            arm_velocity_rad_s=float(qvel[self._arm_v]),
            servo_target_rad=float(self.data.act[0]),
            observation_age_s=age_s,
            time_since_action_s=since_action_s,
        )

    # --- the MCU pipeline (realistic) ---
    def _step_mcu(self, command: ServoCommand) -> RigState:
        now_ms = self._tick * self.params.physics_step_ms
        arrival = max(now_ms + self.fidelity.latency.sample_ms(self._rng), self._last_command_arrival_ms)
        self._last_command_arrival_ms = arrival  # TCP keeps order: no overtaking
        self._commands.append((arrival, command))
        self._sent_ms = now_ms
        self._run_mcu_substeps(self.substeps)
        return self._observe_mcu(time_since_action_s=self.substeps * self.physics_step_s)

    def _run_mcu_substeps(self, count: int) -> None:
        p, mcu, data = self.params, self._mcu, self.data
        physics_ms = p.physics_step_ms
        acting_ticks = round(p.acting_period_ms / physics_ms)
        pwm_ticks = round(p.pwm_period_ms / physics_ms)
        stream_ticks = round(p.streaming_period_ms / physics_ms)
        offset = self.fidelity.encoder_mount_offset_counts
        for _ in range(count):
            tick = self._tick
            now_ms = tick * physics_ms
            while self._commands and self._commands[0][0] <= now_ms:
                mcu.receive(self._commands.popleft()[1], now_ms)
            if tick % acting_ticks == 0:
                mcu.acting_tick(now_ms)
            if tick % pwm_ticks == 0:
                data.act[0] = p.servo_counts_to_rad(mcu.servo_counts)
            if tick % stream_ticks == 0:
                raw = int(rad_to_counts(data.qpos[self._pend_q], offset, p.encoder_counts))
                observation = mcu.streaming_tick(calibrate_position(raw, offset, p.encoder_counts), int(now_ms))
                delivery = max(now_ms + self.fidelity.latency.sample_ms(self._rng), self._last_delivery_ms)
                self._last_delivery_ms = delivery
                self._in_flight.append((delivery, observation))
            mujoco.mj_step(self.model, data)
            self._tick += 1
        now_ms = self._tick * physics_ms
        while self._in_flight and self._in_flight[0][0] <= now_ms:
            self._newest = self._in_flight.popleft()

    def _observe_mcu(self, time_since_action_s: float) -> RigState:
        p = self.params
        delivered_ms, obs = self._newest
        now_ms = self._tick * p.physics_step_ms
        return RigState(
            time_s=obs.millis / 1000.0,
            pendulum_angle_rad=float(counts_to_rad(obs.position_counts, 0, p.encoder_counts)),
            pendulum_velocity_rad_s=obs.omega_rev_s * 2 * math.pi,
            pendulum_acceleration_rad_s2=obs.acceleration_rev_s2 * 2 * math.pi,
            arm_angle_rad=p.servo_counts_to_rad(obs.servo_counts),
            arm_velocity_rad_s=obs.arm_velocity_counts_s * p.servo_rad_per_count,
            servo_target_rad=p.servo_counts_to_rad(self._mcu.servo_counts),
            observation_age_s=(now_ms - delivered_ms) / 1000.0,
            time_since_action_s=time_since_action_s,
            encoder_counts=obs.position_counts,
            safety_flags=obs.flags,
        )

    # --- inspection ---
    def true_state(self) -> dict[str, float]:
        """The twin's exact joint state (for info and tests; a real rig has no such thing)."""
        return {
            "arm_angle_rad": float(self.data.qpos[self._arm_q]),
            "arm_velocity_rad_s": float(self.data.qvel[self._arm_v]),
            "pendulum_angle_rad": float(self.data.qpos[self._pend_q]),
            "pendulum_velocity_rad_s": float(self.data.qvel[self._pend_v]),
            "time_s": float(self.data.time),
        }

    def close(self) -> None:
        """Nothing to release; present for symmetry with the rig backend."""


def _with_age(state: RigState, age_s: float) -> RigState:
    from dataclasses import replace

    return replace(state, observation_age_s=age_s)
