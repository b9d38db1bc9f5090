"""A job's result as the queue stores it (`QueueStore.finish`): a summary (JSON), the telemetry (CSV, one row per
control step) and a plot (PNG).

The summary of a judged job (controller, blob, policy):

    {"kind", "rig", "verdict": "K/N" (episodes held of those asked), "solved": the kit's rule (>= 9 of 10; None
     for fewer than 10 episodes), "held": K, "episodes_run", "time_to_upright_s" (median over the held ones),
     "episodes": [{"held", "steps", "time_to_upright_s", "held_fraction", "flags"}], "episode_steps",
     "control_step_s", "reset_s": [rig seconds per reset], "pushes": {"verdict", "held", "episodes", "solved",
     "time_to_upright_s", "size", "per_episode"} (the same blob on the twin's device, the rule's starts, two
     hand pushes an episode; a line of text while it is judged or when skipped), "stopped": why it ended early}

An excitation job's holds `excitation`: the recordings as `pendkit adapt` writes excitation.json, for the team to
identify its rig on the laptop (`save_excitation`).
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np

from pendkit.agents.policy_rule import REPORT_SEED, RULE_MIN_HELD, RULE_STARTS
from pendkit.agents.runs import held_fraction
from pendkit.backend_contract import FLAG_BITS
from pendkit.deploy.on_twin import upload_to_twin
from pendkit.episode import PALETTE
from pendkit.errors import ConfigError
from pendkit.features import SOLVED_TAIL_STEPS, UPRIGHT_RAD, angle_from_upright_rad, holds_upright, time_to_upright_s
from pendkit.queue.rig_episodes import Sample
from pendkit.rig import RigParams
from pendkit.safe_write import write_text
from pendkit.sim.pushes import PUSH_SIZES_RAD_S, PUSH_WINDOW_STEPS

PUSH_SIZE, PUSHES_PER_EPISODE = "hand", 2  # bench_policies' "pushes" condition
CSV_HEADER = "episode,t_s,angle_from_upright_rad,servo_counts,flags,flag_names"
NOT_COUNTED_FLAGS = frozenset(("watchdog",))  # the host's own pauses (status requests), not the controller's


def verdict(held: list[bool], asked: int) -> tuple[str, bool | None]:
    """("K/N", solved by the kit's rule): N the episodes asked, those not run count as not held."""
    count = sum(held)
    return f"{count}/{asked}", (count >= RULE_MIN_HELD if asked == len(RULE_STARTS) else None)


def median_upright_s(held: list[bool], upright_s: list[float | None]) -> float | None:
    times = [t for t, ok in zip(upright_s, held) if ok and t is not None]
    return round(float(np.median(times)), 3) if times else None


def judged_summary(runs: list[list[Sample]], asked: int, step_s: float) -> dict:
    """The rule on each episode's angles (one per control step), as `pendkit.adapt.routes.judged` does."""
    episodes = []
    for samples in runs:
        angles = [s.angle_from_upright_rad for s in samples]
        upright = time_to_upright_s(angles, step_s) if angles else None
        fraction = held_fraction(angles) if angles else None
        flags = sorted(set().union(*(s.flags for s in samples)) - NOT_COUNTED_FLAGS) if samples else []
        episodes.append({"held": holds_upright(angles, SOLVED_TAIL_STEPS), "steps": len(samples),
                         "time_to_upright_s": None if upright is None else round(upright, 3),
                         "held_fraction": None if fraction is None else round(fraction, 4), "flags": flags})
    held = [e["held"] for e in episodes]
    shown, solved = verdict(held, asked)
    return {"verdict": shown, "solved": solved, "held": sum(held), "episodes_run": len(episodes), "episodes": episodes,
            "time_to_upright_s": median_upright_s(held, [e["time_to_upright_s"] for e in episodes])}


def telemetry_csv(runs: list[list[Sample]]) -> str:
    """One row per control step of every episode: time (the device's, s), angle from upright, servo, flags."""
    rows = [CSV_HEADER]
    for episode, samples in enumerate(runs, start=1):
        for s in samples:
            bits = sum(FLAG_BITS[name] for name in s.flags if name in FLAG_BITS)
            rows.append(f"{episode},{s.t_s:.3f},{s.angle_from_upright_rad:.5f},{s.servo_counts},{bits},"
                        f"{'|'.join(sorted(s.flags))}")
    return "\n".join(rows) + "\n"


def plot_png(runs: list[list[Sample]], title: str, held: list[bool] | None = None) -> bytes:
    """Each episode's |angle from upright| and servo counts against time (Okabe-Ito colours), as PNG bytes."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(9, 5), layout="constrained")
    angle_axes, servo_axes = figure.subplots(2, 1, sharex=True)
    angle_axes.axhspan(0, np.degrees(UPRIGHT_RAD), color=PALETTE["limit"], alpha=0.2, lw=0)
    for k, samples in enumerate(runs):
        if not samples:
            continue
        t = [s.t_s for s in samples]
        ok = held is None or (k < len(held) and held[k])
        angle_axes.plot(t, np.degrees(np.abs([s.angle_from_upright_rad for s in samples])), lw=0.9,
                        color=PALETTE["pendulum"] if ok else PALETTE["arm"], linestyle="-" if ok else "--")
        servo_axes.plot(t, [s.servo_counts for s in samples], lw=0.7, color=PALETTE["action"])
    angle_axes.plot([], [], color=PALETTE["pendulum"], label="held")
    angle_axes.plot([], [], color=PALETTE["arm"], linestyle="--", label="not held")
    angle_axes.legend(loc="upper right")
    angle_axes.set_ylabel("pendulum, |from upright| (deg)")
    servo_axes.set_ylabel("servo (counts)")
    servo_axes.set_xlabel("time in the episode (s, the device's clock)")
    figure.suptitle(title)
    out = io.BytesIO()
    figure.savefig(out, format="png", dpi=80, metadata={"Software": None})
    return out.getvalue()


def twin_with_pushes(blob: bytes, params: dict, episodes: int, episode_steps: int, step_s: float) -> dict:
    """The same blob on the twin's device (the realistic twin of the job's rig, its network), the rule's starts
    (`REPORT_SEED`), two hand pushes an episode (`pendkit.sim.pushes`' window): the leaderboard's other column.
    About 0.1 s of CPU an episode."""
    import pendkit

    env = pendkit.make(action_mode="continuous", fidelity="realistic", filter_coefficient=0.0,
                       params=RigParams(**params))
    backend = env.unwrapped.backend
    first, last = (round(w * episode_steps / 500) for w in PUSH_WINDOW_STEPS)  # the window of a 500-step episode
    held, upright = [], []
    try:
        upload_to_twin(env, blob)
        for k in range(episodes):
            seed = REPORT_SEED + k
            rng = np.random.default_rng([seed, 0x9B5])
            pushes = dict(zip(rng.choice(np.arange(first, last), PUSHES_PER_EPISODE, replace=False).tolist(),
                              rng.choice([-1.0, 1.0], PUSHES_PER_EPISODE) * PUSH_SIZES_RAD_S[PUSH_SIZE]))
            _, info = env.reset(seed=seed, options={"start": RULE_STARTS[k % len(RULE_STARTS)]})
            angles = []
            for step in range(episode_steps):
                running = backend.device.scheduler.status()["controller"]["running"]
                state = backend.step_with_message("h" if running else "k1")
                if step in pushes:
                    backend.push_pendulum(float(pushes[step]))
                angles.append(angle_from_upright_rad(state))
            held.append(holds_upright(angles, SOLVED_TAIL_STEPS))
            upright.append(time_to_upright_s(angles, step_s))
    finally:
        env.close()
    shown, solved = verdict(held, episodes)
    return {"verdict": shown, "solved": solved, "held": sum(held), "episodes": episodes,
            "time_to_upright_s": median_upright_s(held, upright), "size": PUSH_SIZE, "per_episode": PUSHES_PER_EPISODE}


def excitation_summary(recordings: list, rig_range: tuple[int, int] | None) -> dict:
    return {"recorded_episodes": len(recordings), "servo_counts_range": list(rig_range) if rig_range else None,
            "excitation": [recording.as_dict() for recording in recordings]}


def save_excitation(result: dict, folder: str | Path) -> Path:
    """Write an excitation job's recordings as `pendkit adapt` writes them (excitation.json) and its telemetry
    (telemetry.csv) into `folder`; the JSON's path."""

    summary = result["summary"]
    if "excitation" not in summary:
        raise ConfigError("not an excitation job's result: it holds no recordings")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "excitation.json"
    write_text(path, json.dumps(summary["excitation"]))
    write_text(folder / "telemetry.csv", result.get("telemetry_csv") or "")
    return path
