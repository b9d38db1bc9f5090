"""Every graded task: correct answers get full marks; plausible mistakes lose points with a message that
points at the mistake (public and hidden tests together)."""

import math
import struct

import control
import numpy as np
import pytest

from pendkit import encoder
from pendkit.episode import time_to_upright_s
from pendkit.grading import run_task


def score(task_id, fn):
    results = run_task(task_id, fn, include_hidden=True)
    return sum(r.points for r in results), sum(r.max_points for r in results), \
        " ".join(r.message for r in results if not r.passed)


# --- reference answers ---
def final_upright_start(angles, dt):
    return time_to_upright_s(angles, dt)


def first_upright_entry(angles, dt):
    inside = np.nonzero(np.abs(np.asarray(angles, dtype=float)) < 0.3)[0]
    return None if final_upright_start(angles, dt) is None else float(inside[0] * dt)


def balance_error_deg(angles, dt, rms=True):
    start = final_upright_start(angles, dt)
    if start is None:
        return None
    tail = np.asarray(angles, dtype=float)[int(round(start / dt)):]
    return float(np.degrees(np.sqrt(np.mean(tail**2)) if rms else np.mean(tail)))


def policy_verdict(held, starts, strict=False, lucky=False, share=False):
    held, starts = [bool(h) for h in held], list(starts)
    complete = len(held) == 10 and starts.count("rest") == 5 and starts.count("random") == 5
    if lucky:
        solved = held[0]
    elif share:
        solved = sum(held) >= 0.9 * len(held)
    else:
        solved = complete and (sum(held) > 9 if strict else sum(held) >= 9)
    return {"held": sum(held), "episodes": len(held), "solved": solved}


def should_stop(arm, rate, age):
    if not abs(arm) <= 1.6:
        return "arm"
    if not abs(rate) <= 20.0:
        return "spin"
    return None if age <= 0.3 else "stale"


def slew_rate(t, command, arm, interpolate=True):
    t, command, arm = (np.asarray(v, dtype=float) for v in (t, command, arm))
    k = int(np.argmax(command != command[0]))
    progress = (arm[k:] - arm[k - 1]) / (command[k] - arm[k - 1])
    times = t[k:]

    def crossing(level):
        i = int(np.argmax(progress >= level))
        if not interpolate:
            return times[i]
        return times[i - 1] + (level - progress[i - 1]) * (times[i] - times[i - 1]) / (progress[i] - progress[i - 1])

    return 0.8 * abs(command[k] - arm[k - 1]) / (crossing(0.9) - crossing(0.1))


def decode_frame(frame):
    status = encoder.frame_status(frame)
    if status != "ok":
        raise ValueError(status)
    return frame >> 6


def wrap_delta(new, old):
    return int(encoder.wrap_delta_counts(new, old))


CORRECT = {
    "00.reward": lambda theta, omega: -theta**2 - 0.5 * (omega / (2 * math.pi)) ** 2,
    "00.upright_fraction": lambda angles: float(np.mean(np.abs(np.asarray(angles)) < 0.3)),
    "01.decode_frame": decode_frame,
    "01.counts_to_angle": lambda raw, offset: float(encoder.counts_to_rad(raw, offset)),
    "01.angle_from_upright": lambda angle: float(encoder.angle_from_upright_rad(angle)),
    "01.wrap_delta": wrap_delta,
    "02.velocity_rev_s": lambda p, t: encoder.finite_difference_rev_s(p, t),
    "02.firmware_mean": lambda v, w: np.convolve(np.concatenate([np.zeros(w - 1), v]), np.ones(w) / w, "valid"),
    "02.low_pass": lambda v, a: encoder.low_pass(v, a),
    "02.period_limits": lambda ms: (1 / 1024 / (ms / 1000), 0.5 / (ms / 1000)),
    "03.natural_frequency": lambda m, com, j: math.sqrt(m * 9.81 * com / j),
    "03.period_from_crossings": lambda t, a: float(np.mean(np.diff(up_crossings(t, a)))),
    "03.damping_ratio": lambda p: log_decrement(p) / math.sqrt(4 * math.pi**2 + log_decrement(p) ** 2),
    "03.slew_rate": lambda t, command, arm: slew_rate(t, command, arm),
    "04.upright_matrices": lambda model: tuple(np.asarray(m) for m in (model.linearise("upright").A,
                                                                        model.linearise("upright").B)),
    "04.lqr_gain": lambda a, b, q, r: np.asarray(control.dlqr(a, b, np.diag(q), [[r]])[0]),
    "04.closed_loop_poles": lambda a, b, k: np.linalg.eigvals(a - b @ k),
    "05.pendulum_energy": lambda alpha, w, w0: 0.5 * (w / w0) ** 2 - math.cos(alpha),
    "05.pumping_direction": lambda alpha, w: -1 if w * math.cos(alpha) > 0 else 1,
    "05.next_mode": lambda mode, theta, w: next_mode(mode, theta, w),
    "05.path_limits": lambda arm, rev_s: (arm, 2 * math.pi * rev_s),
    "05.catch_set": lambda up, a, w, arm, arm_w: catch_set(up, a, w, arm, arm_w),
    "05.terminal_cost": lambda x, up: terminal_cost(x, up),
    "06.period_error_p99_ms": lambda t, nominal: float(np.percentile(np.abs(np.diff(t) - nominal) * 1000, 99)),
    "06.fit_latency": lambda samples: fit_latency(samples),
    "06.predict_angle": lambda theta, rate, d, w0: theta + rate * d + 0.5 * w0**2 * theta * d**2,
    "07.epsilon": lambda step, start, end, decay: end + (start - end) * max(0.0, 1 - step / decay),
    "07.td_target": lambda r, done, online, target, gamma, double: td_target(r, done, online, target, gamma, double),
    "07.huber": lambda e, delta: np.where(np.abs(e) <= delta, 0.5 * e**2, delta * (np.abs(e) - 0.5 * delta)),
    "07.policy_verdict": lambda held, starts: policy_verdict(held, starts),
    "08.delayed_view": lambda obs, k: np.asarray(obs)[np.maximum(0, np.arange(len(obs)) - k)],
    "08.gru_step": lambda x, h, w_ih, w_hh, b_ih, b_hh: gru_step(x, h, w_ih, w_hh, b_ih, b_hh),
    "09.time_to_upright_s": lambda angles, dt: final_upright_start(angles, dt),
    "09.balance_error_deg": lambda angles, dt: balance_error_deg(angles, dt),
    "09.should_stop": lambda arm, rate, age: should_stop(arm, rate, age),
    "09.matching_cost": lambda sim, rec: float(np.mean(((np.asarray(sim) - rec + np.pi) % (2 * np.pi) - np.pi) ** 2)),
    "08.augmented_state": lambda obs, recent, n: augmented_state(obs, recent, n),
    "08.breaking_delay": lambda d, p, r, t=0.5: next((a for a, b, c in zip(d, p, r) if b < t <= c), None),
    "10.pendulum_acceleration": lambda a, w, p, w0, d, k: pendulum_acceleration(a, w, p, w0, d, k),
    "10.upload_chunks": lambda blob, start=0, size=1024: upload_chunks(blob, start, size),
}


def pendulum_acceleration(angle, rate, push, w0, damping, coupling, push_sign=-1.0):
    return -w0**2 * math.sin(angle) - damping * rate + push_sign * coupling * math.cos(angle) * push


def upload_chunks(blob, start=0, size=1024, order="<", whole_size=True):
    return [b"PKUP" + struct.pack(order + "II", offset, len(blob) if whole_size else len(blob[offset:offset + size]))
            + blob[offset:offset + size] for offset in range(start, len(blob), size)]


def shared_buffer_augmented_state():
    """The aliasing bug: one array for the codes, made once and filled again on every call."""
    buffer = {}

    def augmented(observation, recent, n):
        codes = buffer.setdefault((len(recent), n), np.zeros((len(recent), n)))
        codes[np.arange(len(recent)), list(recent)] = 1.0
        return np.concatenate([np.asarray(observation, dtype=float).ravel(), codes.ravel()])

    return augmented


def augmented_state(observation, recent, n, oldest_first=False, one_hot=True):
    recent = list(recent)[::-1] if oldest_first else list(recent)
    codes = np.eye(n)[recent].ravel() if one_hot else np.asarray(recent, dtype=float)
    return np.concatenate([np.asarray(observation, dtype=float).ravel(), codes])


def gru_step(x, h, w_ih, w_hh, b_ih, b_hh, swap_update=False):
    size = len(h)
    gi, gh = w_ih @ x + b_ih, w_hh @ h + b_hh
    reset = 1 / (1 + np.exp(-(gi[:size] + gh[:size])))
    update = 1 / (1 + np.exp(-(gi[size:2 * size] + gh[size:2 * size])))
    new = np.tanh(gi[2 * size:] + reset * gh[2 * size:])
    return update * new + (1 - update) * h if swap_update else (1 - update) * new + update * h


def td_target(rewards, dones, online_q, target_q, gamma, double, mask_terminal=True):
    rows = np.arange(len(rewards))
    future = target_q[rows, online_q.argmax(axis=1)] if double else target_q.max(axis=1)
    return rewards + gamma * (1 - dones if mask_terminal else 1) * future


def fit_latency(samples, subtract_floor=True):
    samples = np.asarray(samples, float)
    floor = samples.min()
    above = samples - floor if subtract_floor else samples
    return floor, float(np.median(above)), float(np.std(np.log(above[above > 0])))


def up_crossings(t, a, interpolate=True):
    t, a = np.asarray(t, float), np.asarray(a, float)
    up = np.nonzero((a[:-1] < 0) & (a[1:] >= 0))[0]
    if not interpolate:
        return t[up + 1]
    return t[up] - a[up] * (t[up + 1] - t[up]) / (a[up + 1] - a[up])


def log_decrement(peaks, log=np.log):
    peaks = np.asarray(peaks, float)
    return float(np.mean(log(peaks[:-1] / peaks[1:])))


def period_counting_both_directions(t, a):
    crossings = np.sort(np.concatenate([up_crossings(t, a), up_crossings(t, -np.asarray(a))]))
    return float(np.mean(np.diff(crossings)))


def damping_with_log10(peaks):
    delta = log_decrement(peaks, np.log10)
    return delta / math.sqrt(4 * math.pi**2 + delta**2)


def catch_set(upright, angle, velocity, arm, arm_velocity, centre=None, one_sided=False):
    centre = upright if centre is None else centre
    low_rate = 0.0 if one_sided else 1.0
    return ([-arm, centre - angle, -low_rate * arm_velocity, -low_rate * velocity],
            [arm, centre + angle, arm_velocity, velocity])


def terminal_cost(x, upright):
    return 0.1 * x[0] ** 2 + 10 * (x[1] - upright) ** 2 + 0.1 * x[2] ** 2 + x[3] ** 2


def next_mode(mode, theta, w, catch=0.8, fall=1.1, check_velocity=True):
    if mode == "swing" and abs(theta) < catch and (abs(w) < 5.0 or not check_velocity):
        return "balance"
    if mode == "balance" and abs(theta) > fall:
        return "swing"
    return mode


def upright_matrices_with(model, gravity_sign=1.0, coupling=True, coupling_sign=-1.0, arm_damping=True):
    off_diagonal = coupling_sign * model.coupling_kg_m2 if coupling else 0.0
    mass = np.array([[model.arm_inertia_kg_m2, off_diagonal], [off_diagonal, model.pendulum_inertia_kg_m2]])
    damping = model.servo_kv_n_m_s_per_rad + (model.arm_damping_n_m_s_per_rad if arm_damping else 0.0)
    forces = np.array([
        [-model.servo_kp_n_m_per_rad, 0, -damping, 0],
        [0, gravity_sign * model.gravity_torque_n_m, 0, -model.pendulum_damping_n_m_s_per_rad]])
    a = np.zeros((4, 4))
    a[0, 2] = a[1, 3] = 1
    a[2:] = np.linalg.inv(mass) @ forces
    b = np.zeros((4, 1))
    b[2:, 0] = np.linalg.inv(mass) @ [model.servo_kp_n_m_per_rad, 0]
    return a, b


@pytest.mark.parametrize("task_id", sorted(CORRECT))
def test_correct_answers_get_full_marks(all_tests_loaded, task_id):
    got, total, messages = score(task_id, CORRECT[task_id])
    assert got == total > 0, messages


# --- plausible mistakes: (task, function, words the feedback must contain) ---
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


def counts_over_1023(raw, offset):
    return ((raw - offset) % 1024) * 2 * math.pi / 1023


def counts_without_wrap(raw, offset):
    return (raw - offset) * 2 * math.pi / 1024


def velocity_no_wrap(p, t):
    return np.diff(np.asarray(p, float)) * 1000 / (1024 * np.diff(np.asarray(t, float)))


def velocity_rad_s(p, t):
    return encoder.finite_difference_rev_s(p, t) * 2 * math.pi


def velocity_seconds(p, t):
    return encoder.finite_difference_rev_s(p, t) / 1000


def velocity_1023(p, t):
    return encoder.finite_difference_rev_s(p, t) * 1024 / 1023


def mean_without_zero_padding(v, w):
    v = np.asarray(v, float)
    return np.array([v[max(0, k - w + 1): k + 1].mean() for k in range(len(v))])


def mean_centred(v, w):
    return np.convolve(v, np.ones(w) / w, mode="same")


MISTAKES = [
    ("00.reward", lambda theta, omega: -theta**2 - 0.5 * omega**2, "rev/s"),
    ("00.reward", lambda theta, omega: theta**2 + 0.5 * (omega / (2 * math.pi)) ** 2, "never positive"),
    ("00.upright_fraction", lambda angles: float(np.mean(np.asarray(angles) < 0.3)), "absolute value"),
    ("00.upright_fraction", lambda angles: int(np.sum(np.abs(np.asarray(angles)) < 0.3)), "count"),
    ("01.decode_frame", decode_lsb_first, "bits reversed"),
    ("01.decode_frame", decode_ignoring_parity, "parity"),
    ("01.decode_frame", decode_ignoring_status, "OCF"),
    ("01.decode_frame", decode_rejecting_one_magnet_bit, "only one magnet bit"),
    ("01.decode_frame", decode_whole_frame, "whole frame"),
    ("01.decode_frame", decode_off_by_one_shift, "frame >> 6"),
    ("01.counts_to_angle", counts_in_degrees, "degrees"),
    ("01.counts_to_angle", counts_adding_offset, "added the offset"),
    ("01.counts_to_angle", counts_over_1023, "not 1023"),
    ("01.counts_to_angle", counts_without_wrap, "negative"),
    ("01.angle_from_upright", lambda angle: angle - math.pi, "wrap into [-pi, pi)"),
    ("01.angle_from_upright", lambda angle: angle, "still the angle from the bottom"),
    ("01.wrap_delta", lambda new, old: new - old, "long way round"),
    ("01.wrap_delta", lambda new, old: -wrap_delta(new, old), "wrong sign"),
    ("01.wrap_delta", lambda new, old: (new - old + 512) % 1024 - 512, "exactly half a turn"),
    ("02.velocity_rev_s", velocity_no_wrap, "wrap-aware"),
    ("02.velocity_rev_s", velocity_rad_s, "rad/s"),
    ("02.velocity_rev_s", velocity_seconds, "milliseconds"),
    ("02.velocity_rev_s", velocity_1023, "not 1023"),
    ("02.firmware_mean", mean_without_zero_padding, "full of zeros"),
    ("02.firmware_mean", mean_centred, "looks ahead"),
    ("02.low_pass", lambda v, a: encoder.low_pass(v, 1 - a) if a < 1 else np.asarray(v, float), "1 - alpha"),
    ("02.period_limits", lambda ms: (1 / 1024 / (ms / 1000), 1 / (ms / 1000)), "half a turn"),
    ("02.period_limits", lambda ms: (2 * math.pi / 1024 / (ms / 1000), 0.5 / (ms / 1000)), "rad/s"),
    ("03.natural_frequency", lambda m, com, j: m * 9.81 * com / j, "square root"),
    ("03.natural_frequency", lambda m, com, j: math.sqrt(m * 9.81 * com / j) / (2 * math.pi), "Hz"),
    ("03.natural_frequency", lambda m, com, j: math.sqrt(9.81 / com), "point mass"),
    ("03.period_from_crossings", lambda t, a: period_counting_both_directions(t, a), "both directions"),
    ("03.period_from_crossings", lambda t, a: float(np.mean(np.diff(up_crossings(t, a, interpolate=False)))),
     "interpolation"),
    ("03.damping_ratio", lambda p: log_decrement(p), "decrement itself"),
    ("03.damping_ratio", lambda p: log_decrement(p) / (2 * math.pi), "light damping"),
    ("03.damping_ratio", lambda p: damping_with_log10(p), "log10"),
    ("03.slew_rate", lambda t, c, a: -slew_rate(t, c, a) if c[-1] < c[0] else slew_rate(t, c, a), "positive"),
    ("03.slew_rate", lambda t, c, a: slew_rate(t, c, a) / 0.8, "80 %"),
    ("03.slew_rate", lambda t, c, a: slew_rate(t, c, a, interpolate=False), "interpolation"),
    ("04.upright_matrices", lambda model: upright_matrices_with(model, gravity_sign=-1.0), "wrong sign"),
    ("04.upright_matrices", lambda model: upright_matrices_with(model, coupling=False), "coupling"),
    ("04.lqr_gain", lambda a, b, q, r: np.asarray(control.lqr(a, b, np.diag(q), [[r]])[0]), "continuous-time"),
    ("04.lqr_gain", lambda a, b, q, r: -np.asarray(control.dlqr(a, b, np.diag(q), [[r]])[0]), "wrong sign"),
    ("04.closed_loop_poles", lambda a, b, k: np.linalg.eigvals(a + b @ k), "A + B K"),
    ("05.pendulum_energy", lambda alpha, w, w0: 0.5 * (w / w0) ** 2 + math.cos(alpha), "sign is flipped"),
    ("05.pendulum_energy", lambda alpha, w, w0: (w / w0) ** 2 - math.cos(alpha), "factor 1/2"),
    ("05.pendulum_energy", lambda alpha, w, w0: 0.5 * w**2 - math.cos(alpha), "natural frequency"),
    ("05.pumping_direction", lambda alpha, w: 1 if w * math.cos(alpha) > 0 else -1, "against"),
    ("05.pumping_direction", lambda alpha, w: -1 if w > 0 else 1, "above horizontal"),
    ("05.next_mode", lambda mode, theta, w: next_mode(mode, theta, w, fall=0.8), "hysteresis"),
    ("05.next_mode", lambda mode, theta, w: next_mode(mode, theta, w, check_velocity=False), "fly through"),
    ("05.path_limits", lambda arm, rev_s: (arm, rev_s), "revolutions to radians"),
    ("05.catch_set", lambda up, a, w, arm, arm_w: catch_set(up, a, w, arm, arm_w, centre=0.0), "around hanging"),
    ("05.catch_set", lambda up, a, w, arm, arm_w: catch_set(up, a, w, arm, arm_w, one_sided=True), "both sides"),
    ("05.terminal_cost", lambda x, up: terminal_cost(x, 0.0), "not from 0"),
    ("06.period_error_p99_ms", lambda t, n: float(np.percentile(np.abs(np.diff(t) - n), 99)), "seconds"),
    ("06.period_error_p99_ms", lambda t, n: float(np.percentile((np.diff(t) - n) * 1000, 99)), "absolute error"),
    ("06.fit_latency", lambda samples: fit_latency(samples, subtract_floor=False), "subtract the floor"),
    ("06.predict_angle", lambda theta, rate, d, w0: theta + rate * d, "left out gravity"),
    ("06.predict_angle", lambda theta, rate, d, w0: theta + rate * d - 0.5 * w0**2 * theta * d**2, "not minus"),
    ("07.epsilon", lambda step, start, end, decay: start + (end - start) * step / decay, "stop at the end value"),
    ("07.td_target", lambda r, done, on, tq, g, double: td_target(r, done, on, tq, g, False), "plain max"),
    ("07.td_target", lambda r, done, on, tq, g, double: td_target(r, done, on, tq, g, double, False), "no future"),
    ("07.huber", lambda e, delta: 0.5 * np.asarray(e) ** 2, "grows linearly"),
    ("07.huber", lambda e, delta: np.where(np.abs(e) <= delta, 0.5 * e**2, np.abs(e)), "subtract 0.5 delta"),
    ("07.policy_verdict", lambda held, starts: policy_verdict(held, starts, strict=True), "9 passes"),
    ("07.policy_verdict", lambda held, starts: policy_verdict(held, starts, lucky=True), "one lucky episode"),
    ("07.policy_verdict", lambda held, starts: policy_verdict(held, starts, share=True), "the rule takes 10"),
    ("08.delayed_view", lambda obs, k: np.roll(obs, k, axis=0), "np.roll"),
    ("08.delayed_view", lambda obs, k: np.asarray(obs), "nothing is delayed"),
    ("08.gru_step", lambda x, h, a, b, c, d: gru_step(x, h, a, b, c, d, swap_update=True), "swapped"),
    ("08.augmented_state", lambda o, r, n: augmented_state(o, r, n, oldest_first=True), "wrong order"),
    ("08.augmented_state", lambda o, r, n: augmented_state(o, r, n, one_hot=False), "one-hot codes"),
    ("08.breaking_delay", lambda d, p, r, t=0.5: d[int(np.argmin(p))], "first breaks"),
    ("08.breaking_delay", lambda d, p, r, t=0.5: next((x for x, a, b in zip(d, p, r) if a <= t <= b), None),
     "not <="),
    ("08.breaking_delay", lambda d, p, r, t=0.5: next((x for x, a, b in zip(d, p, r) if a < t < b), None), "not >"),
    ("08.augmented_state", shared_buffer_augmented_state(), "shared between calls"),
    ("04.upright_matrices", lambda model: upright_matrices_with(model, coupling_sign=1.0), "coupling's sign"),
    ("04.upright_matrices", lambda model: upright_matrices_with(model, arm_damping=False), "back-EMF"),
    ("04.closed_loop_poles", lambda a, b, k: np.abs(np.linalg.eigvals(np.asarray(a) - np.asarray(b) @ k)),
     "magnitudes"),
    ("07.td_target", lambda r, done, online, target, gamma, double: td_target(r, 1 - np.asarray(done), online,
                                                                               target, gamma, double),
     "kept it only where it ended"),
    ("07.td_target", lambda r, done, online, target, gamma, double: td_target(r, done, target, online, gamma, double)
     if double else td_target(r, done, online, target, gamma, double), "roles are swapped"),
    ("07.td_target", lambda r, done, online, target, gamma, double: np.asarray(r) + gamma * (1 - np.asarray(done))
     * np.asarray(target).max(axis=0), "over axis=1, the actions"),
    ("07.epsilon", lambda step, start, end, decay: start + (end - start) * min(1.0, (step + 1) / decay), "off by one"),
    ("07.huber", lambda e, delta: np.where(np.abs(e) <= delta, np.asarray(e) ** 2, delta * (np.abs(e) - 0.5 * delta)),
     "half the square"),
    ("09.time_to_upright_s", lambda a, dt: first_upright_entry(a, dt), "only the final run counts"),
    ("09.matching_cost", lambda sim, rec: float(np.mean((np.asarray(sim) - rec + np.pi) % (2 * np.pi) - np.pi) ** 2),
     "cancelled"),
    ("09.matching_cost", lambda sim, rec: float(np.mean(((np.asarray(sim) - rec) % (2 * np.pi)) ** 2)),
     "not [0, 2 pi)"),
    ("09.time_to_upright_s", lambda a, dt: final_upright_start(np.abs(np.maximum(a, 0.0)), dt), "compare |angle|"),
    ("09.time_to_upright_s", lambda a, dt: None if final_upright_start(a, dt) is None
     else round(final_upright_start(a, dt) / dt), "step index"),
    ("09.balance_error_deg", lambda a, dt: balance_error_deg(a, dt, rms=False), "mean"),
    ("09.balance_error_deg", lambda a, dt: None if balance_error_deg(a, dt) is None
     else math.radians(balance_error_deg(a, dt)), "radians"),
    ("09.should_stop", lambda arm, rate, age: "arm" if abs(arm) > 1.6 or abs(rate) > 20 or age > 0.3 else None,
     "not a number"),
    ("09.should_stop", lambda arm, rate, age: "arm" if arm > 1.6 or rate > 20 or not age <= 0.3 else None,
     "either way"),
    ("10.pendulum_acceleration", lambda a, w, p, w0, d, k: pendulum_acceleration(a, w, p, w0, d, k, 1.0),
     "wrong sign"),
    ("10.pendulum_acceleration", lambda a, w, p, w0, d, k: pendulum_acceleration(a, w, 0.0, w0, d, k), "missing"),
    ("10.upload_chunks", lambda blob, start=0, size=1024: upload_chunks(blob, start, size, ">"), "big-endian"),
    ("10.upload_chunks", lambda blob, start=0, size=1024: upload_chunks(blob, start, size, whole_size=False),
     "whole blob's size"),
    ("10.upload_chunks", lambda blob, start=0, size=1024: upload_chunks(blob, 0, size), "offsets"),
]


@pytest.mark.parametrize("task_id, fn, words", MISTAKES, ids=[f"{m[0]}-{m[2]}" for m in MISTAKES])
def test_mistakes_lose_points_with_a_pointed_message(all_tests_loaded, task_id, fn, words):
    got, total, messages = score(task_id, fn)
    assert got < total
    assert words in messages, messages


def test_a_stub_scores_zero_and_says_not_implemented(all_tests_loaded):
    def stub(*args):
        raise NotImplementedError("not implemented yet")

    for task_id in CORRECT:
        got, total, messages = score(task_id, stub)
        assert got == 0 and "not implemented yet" in messages, task_id


def test_a_hanging_answer_times_out(all_tests_loaded, monkeypatch):
    monkeypatch.setenv("PENDKIT_CHECK_TIMEOUT_S", "0.2")

    def hang(theta, omega):
        while True:
            pass

    got, total, messages = score("00.reward", hang)
    assert got == 0 and "took longer than 0.2 s" in messages


def test_check_prints_and_strict_mode_raises(all_tests_loaded, monkeypatch, capsys):
    from pendkit.grading import GradingError, check

    monkeypatch.setenv("PENDKIT_MODE", "interactive")
    monkeypatch.setenv("PENDKIT_GRADER_STRICT", "0")
    assert check("01.wrap_delta", lambda new, old: new - old) == 2
    assert "FAIL  differences_across_the_seam" in capsys.readouterr().out
    monkeypatch.setenv("PENDKIT_GRADER_STRICT", "1")
    with pytest.raises(GradingError, match="01.wrap_delta scored 2/5"):
        check("01.wrap_delta", lambda new, old: new - old)
    assert check("01.wrap_delta", wrap_delta) == 5  # full marks never raise


@pytest.mark.parametrize("task_id, fn, misleading", [
    ("02.velocity_rev_s", velocity_no_wrap, "Intervals need not be equal"),
    ("03.period_from_crossings", lambda t, a: period_counting_both_directions(t, a), "without interpolation"),
    ("04.upright_matrices", lambda model: upright_matrices_with(model, gravity_sign=-1.0), "Use the model's fields"),
])
def test_one_mistake_is_not_blamed_on_something_else(all_tests_loaded, task_id, fn, misleading):
    """A single bug fails the test about it; the other tests either pass or say they depend on it."""
    _, _, messages = score(task_id, fn)
    assert misleading not in messages, messages


def test_a_damping_ratio_near_the_answer_shows_how_far_off_it_is(all_tests_loaded):
    """Rounding must not hide the difference: 0.0199 against 0.02 reads as different numbers."""
    _, _, messages = score("03.damping_ratio", lambda p: 0.995 * log_decrement(p) / math.sqrt(
        4 * math.pi**2 + log_decrement(p) ** 2))
    assert "got 0.0199" in messages and "-0.50%" in messages, messages


def test_feedback_shows_numpy_numbers_as_numbers(all_tests_loaded):
    _, _, messages = score("09.time_to_upright_s", lambda angles, dt: np.float64(0.24))
    assert "got 0.24" in messages and "np.float64" not in messages, messages
    _, _, messages = score("09.balance_error_deg", lambda angles, dt: 76.9508191732133)
    assert "got 76.9508" in messages and "76.9508191732133" not in messages, messages
