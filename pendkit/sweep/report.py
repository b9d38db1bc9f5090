"""A sweep folder's results as one tidy table (table.csv and table.json: one row per trial), the summary
lines the benchmarks print, a figure, and lab 08's delay-sweep file (`pendkit.agents.results`' format)."""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

from pendkit.agents.policy_rule import RULE_TEXT
from pendkit.errors import ConfigError
from pendkit.rig import RigParams
from pendkit.safe_write import check_no_links, replacing, write_text
from pendkit.sweep.ray_runner import SPEC_COPY, trial_line
from pendkit.sweep.trial import RESULT

TRIAL_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,200}")  # what Trial.trial_id makes: a folder name

COLUMNS = ("trial_id", "learner", "setting_name", "seed", "solved", "episodes_to_solve", "wall_s_to_solve",
           "policy_solved", "held_out_solved", "episodes", "wall_s", "max_episodes", "max_wall_s",
           "resumed_from_episode", "host", "node_id", "curve", "source", "solved_rule")


def solved_rule(budget: dict) -> str:
    return (f"{RULE_TEXT}; judged every {budget['check_every']} episodes on the training starts, "
            "policy_solved on the reporting starts")


def gather_many(folders: list[Path], skipped: list[str] | None = None) -> tuple[list[dict], list[str]]:
    """Several sweep folders as one table (a class's runs, each student's seeds): each row says its folder.
    A folder that is not a readable sweep is left out, its reason appended to `skipped`."""
    rows, missing = [], []
    skipped = skipped if skipped is not None else []
    for folder in folders:
        try:
            found, absent = gather(folder, skipped)
        except ConfigError as error:
            skipped.append(str(error))
            continue
        rows += [row | {"source": str(folder), "curve": str(Path(folder) / row["curve"])} for row in found]
        missing += absent
    return rows, missing


def gather(out: str | Path, skipped: list[str] | None = None) -> tuple[list[dict], list[str]]:
    """(finished rows in the spec's order, ids of trials not finished yet). A trial whose result.json is
    not what a trial writes is left out, its reason appended to `skipped`."""
    out = Path(out)
    if not (out / SPEC_COPY).exists():
        raise ConfigError(f"{out} is not a sweep folder (no {SPEC_COPY}): run `pendkit sweep SPEC --out {out}`")
    try:
        trials = json.loads((out / SPEC_COPY).read_text())["trials"]
        ids = [str(trial["trial_id"]) for trial in trials]
    except (ValueError, KeyError, TypeError, UnicodeDecodeError) as error:
        raise ConfigError(f"{out / SPEC_COPY} is not a sweep's record ({type(error).__name__}): "
                          "left out") from None
    rows, missing = [], []
    for trial, trial_id in zip(trials, ids):
        if not TRIAL_ID.fullmatch(trial_id):
            (skipped if skipped is not None else []).append(f"{out}: a trial id {trial_id[:40]!r} that is no "
                                                            "folder name: left out")
            continue
        path = out / "trials" / trial_id / RESULT
        if not path.exists():
            missing.append(trial_id)
            continue
        try:
            row = _checked_row(json.loads(path.read_text()), trial)
        except (ValueError, KeyError, TypeError, UnicodeDecodeError) as error:
            (skipped if skipped is not None else []).append(f"{path}: not a trial's result ({error}): left out")
            continue
        budget = row["budget"]
        rows.append(row | {"max_episodes": budget["max_episodes"], "max_wall_s": budget["max_wall_s"],
                           "solved_rule": solved_rule(budget)})
    return rows, missing


def _checked_row(row, trial: dict) -> dict:
    """`row` if it is what `run_trial` writes for `trial` (its learner, setting and seed, fields of the
    right types); ValueError naming what is wrong otherwise."""
    if not isinstance(row, dict):
        raise ValueError("not a mapping")
    for key in ("learner", "setting_name", "seed"):
        if row.get(key) != trial.get(key):
            raise ValueError(f"its {key} is {row.get(key)!r}, the spec's {trial.get(key)!r}")
    if not isinstance(row.get("solved"), bool):
        raise ValueError("solved is not true or false")
    for key in ("episodes", "wall_s"):
        if isinstance(row.get(key), bool) or not isinstance(row.get(key), (int, float)) or row[key] < 0:
            raise ValueError(f"{key} is not a number >= 0")
    if row["solved"] and not (isinstance(row.get("episodes_to_solve"), int)
                              and isinstance(row.get("wall_s_to_solve"), (int, float))):
        raise ValueError("solved without episodes_to_solve and wall_s_to_solve")
    budget = row.get("budget")
    if not isinstance(budget, dict) or not all(isinstance(budget.get(k), (int, float)) for k in
                                               ("max_episodes", "max_wall_s", "check_every")):
        raise ValueError("its budget is not the trial's")
    if not isinstance(row.get("trial_id"), str) or not isinstance(row.get("curve"), str):
        raise ValueError("trial_id or curve is not text")
    return row


OUTPUTS = ("table.csv", "table.json", "summary.png")  # what a report writes into its folder


def write_table(out: str | Path, rows: list[dict]) -> None:
    """table.csv and table.json, each replaced whole; a link planted at either is refused, never followed."""
    out = Path(out)
    with replacing(out / "table.csv", newline="") as handle:
        writer = csv.DictWriter(handle, COLUMNS, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    write_text(out / "table.json", json.dumps([{k: row.get(k) for k in COLUMNS} for row in rows], indent=1) + "\n")


def summary_lines(rows: list[dict], missing: list[str]) -> list[str]:
    """A line per trial, a line per learner and setting (the benchmarks' format), a line per learner."""
    import numpy as np

    lines = [trial_line(row) for row in rows]
    groups: dict[tuple[str, str], list[dict]] = {}
    for row in rows:
        groups.setdefault((row["learner"], row["setting_name"]), []).append(row)
    for (learner, setting), members in groups.items():
        won = [r for r in members if r["solved"]]
        episodes = f"{np.median([r['episodes_to_solve'] for r in won]):.0f}" if won else "nan"
        wall = f"{np.median([r['wall_s_to_solve'] for r in won]):.0f}" if won else "nan"
        held, tried = _held_out(members)
        lines.append(f"algo={learner} fidelity={setting} solved={len(won)}/{len(members)} "
                     f"median_episodes_to_policy={episodes} median_wall_s_to_policy={wall} "
                     f"held_out={sum(bool(r.get('held_out_solved')) for r in members)}/{len(members)} "
                     f"policy_solved={held}/{tried}")
    for learner in dict.fromkeys(r["learner"] for r in rows):
        parts = " ".join(f"{setting}={sum(r['solved'] for r in members)}/{len(members)}"
                         for (name, setting), members in groups.items() if name == learner)
        lines.append(f"summary algo={learner} {parts}")
    lines += delay_lines(rows)
    cpu_s = sum(r["wall_s"] for r in rows)
    lines.append(f"sweep trials={len(rows) + len(missing)} finished={len(rows)} unfinished={len(missing)} "
                 f"cpu_hours={cpu_s / 3600:.2f} mean_trial_s={cpu_s / max(1, len(rows)):.0f}")
    return lines


def _held_out(rows: list[dict]) -> tuple[int, int]:
    """Episodes held / run on the reporting starts, over the rows (a row's `policy_solved` is "k/n")."""
    held = tried = 0
    for row in rows:
        k, _, n = str(row.get("policy_solved") or "0/0").partition("/")
        if k.isdigit() and n.isdigit() and int(k) <= int(n):  # a hand-edited row counts for nothing
            held, tried = held + int(k), tried + int(n)
    return held, tried


def delay_lines(rows: list[dict]) -> list[str]:
    """For a delay sweep, a line per learner: the share solved at each delay, and the largest delay at least
    half the seeds solved (the benchmarks' `sweep algo=...` line); none for other settings."""
    delays = _delays_ms(rows)
    if delays is None:
        return []
    lines = []
    for learner in dict.fromkeys(r["learner"] for r in rows):
        rates = [(delays[s], _share(rows, learner, s)) for s in sorted(delays, key=delays.get)]
        holding = [delay for delay, rate in rates if rate >= 0.5]
        lines.append(f"sweep algo={learner} success_rate: " + " ".join(f"{d:g}ms={r:.2f}" for d, r in rates)
                     + f" largest_delay_solved_ms={max(holding, default=float('nan')):g}")
    return lines


def plot_summary(rows: list[dict], path: str | Path) -> Path:
    """Share of seeds solved per learner: against the delay when the settings are delays, else per setting."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    delays = _delays_ms(rows)
    figure, axis = plt.subplots(figsize=(7, 3.5))
    learners = list(dict.fromkeys(r["learner"] for r in rows))
    settings = list(dict.fromkeys(r["setting_name"] for r in rows))
    for k, learner in enumerate(learners):
        shares = [_share(rows, learner, s) for s in settings]
        if delays is not None:
            axis.plot([delays[s] for s in settings], shares, "o-", label=learner)
        else:
            width = 0.8 / len(learners)
            axis.bar([i + k * width for i in range(len(settings))], shares, width, label=learner)
    if delays is not None:
        axis.set_xlabel("observation delay (ms)")
    else:
        axis.set_xticks([i + 0.4 - 0.4 / len(learners) for i in range(len(settings))], settings, rotation=15)
    seeds = len({r["seed"] for r in rows})
    axis.set_ylabel(f"share of the {seeds} seeds solved")
    axis.set_ylim(-0.05, 1.05)
    axis.legend()
    figure.tight_layout()
    with replacing(path, binary=True) as handle:
        figure.savefig(handle, format="png", dpi=120)
    plt.close(figure)
    return Path(path)


def delay_sweep_record(rows: list[dict], command: str) -> dict:
    """Lab 08's file (read by `pendkit.agents.results.delay_sweep`) from a sweep over delays."""
    if _delays_ms(rows) is None:
        raise ConfigError("a delay-sweep file needs a sweep whose settings are all delay_steps or all delay_ms")
    return runs_record(rows, command)


def runs_record(rows: list[dict], command: str) -> dict:
    """Every learner's result per setting and seed (episodes to solve or null); a delay sweep's delays in ms
    (null for other settings): the benchmarks' --json format."""
    delays = _delays_ms(rows)
    settings = (sorted(delays, key=delays.get) if delays is not None
                else list(dict.fromkeys(r["setting_name"] for r in rows)))
    budget = rows[0]["budget"]
    runs = []
    for setting in settings:
        for learner in dict.fromkeys(r["learner"] for r in rows):
            members = sorted((r for r in rows if r["learner"] == learner and r["setting_name"] == setting),
                             key=lambda r: r["seed"])
            runs.append({"algo": learner, "setting": setting,
                         "episodes": [r["episodes_to_solve"] if r["solved"] else None for r in members],
                         "wall_s": [r["wall_s_to_solve"] if r["solved"] else r["wall_s"] for r in members]})
    return {"command": command,
            "solved_rule": solved_rule(budget),
            "max_episodes": budget["max_episodes"], "max_wall_s": budget["max_wall_s"],
            "delays_ms": [delays[s] for s in settings] if delays is not None else None, "runs": runs}


def _delays_ms(rows: list[dict]) -> dict[str, float] | None:
    kinds = {r["setting"]["kind"] for r in rows}
    if kinds == {"delay_ms"}:
        return {r["setting_name"]: float(r["setting"]["value"]) for r in rows}
    if kinds == {"delay_steps"}:
        step_ms = RigParams().control_step_ms
        return {r["setting_name"]: float(r["setting"]["value"]) * step_ms for r in rows}
    return None


def _share(rows: list[dict], learner: str, setting: str) -> float:
    members = [r for r in rows if r["learner"] == learner and r["setting_name"] == setting]
    return sum(r["solved"] for r in members) / len(members) if members else float("nan")


def report(out: str | Path, say=print, figure: bool = True, more: list[Path] = ()) -> list[dict]:
    """Gather, write table.csv/json (and summary.png) into `out`, print the summary lines; returns the rows.
    With `more` folders, their trials join `out`'s in one table (a class's seeds side by side)."""
    out = Path(out)
    for name in OUTPUTS:  # said before anything is read or written
        check_no_links(out / name)
    skipped: list[str] = []
    if more:  # DIR may be a sweep of its own or just where the class's table goes
        out.mkdir(parents=True, exist_ok=True)
        rows, missing = gather_many(([out] if (out / SPEC_COPY).exists() else []) + list(more), skipped)
    else:
        rows, missing = gather(out, skipped)
    for reason in skipped:
        say(f"skipped: {reason}")
    write_table(out, rows)
    for line in summary_lines(rows, missing):
        say(line)
    if missing:
        say(f"not finished: {', '.join(missing)} (continue with `pendkit sweep SPEC --out {out} --resume`)")
    if figure and rows:
        say(f"figure: {plot_summary(rows, Path(out) / 'summary.png')}")
    return rows
