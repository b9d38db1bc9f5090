"""One trial of a sweep, in its own folder: learn, judge the greedy policy every `check_every` episodes by
the kit's rule (`pendkit.agents.policy_rule`, on the training starts), stop when solved or out of budget,
then evaluate the final policy on the rule's reporting starts (which training never saw). Everything it
needs to resume is on disk:

    trials/<id>/checkpoint.pt   the kit's training checkpoint (pendkit.agents.checkpoint), every check
    trials/<id>/curve.csv       return of every training episode (the learning curve)
    trials/<id>/checks.csv      every check: episodes, wall seconds, solved, the screen's return, held k/n
    trials/<id>/weights.pt      the final agent (pendkit eval reads it)
    trials/<id>/result.json     written last: a trial with it is finished and never run again

Wall time counts learning and checks, across resumes (a resumed trial adds to what it had spent).
"""

from __future__ import annotations

import csv
import json
import os
import socket
import time
from pathlib import Path

from pendkit.rig import RigParams
from pendkit.safe_write import write_text
from pendkit.sim.fidelity import observation_delay_fidelity
from pendkit.sweep.spec import Trial

# pendkit modules that load torch and MuJoCo are imported inside the functions that use them: importing this module
# does not need them (start-up; torch is an optional extra).

RESULT = "result.json"


def run_spec_and_params(trial: Trial):
    """(RunSpec, RigParams or None) of a trial's setting."""
    from pendkit.agents.runs import RunSpec

    kind, value = trial.setting.kind, trial.setting.value
    common = {"seed": trial.seed, "randomize": trial.randomize, "agent": dict(trial.agent)}
    if kind == "delay_steps":
        return RunSpec(trial.learner, "ideal", delay_steps=int(value), **common), None
    if kind == "delay_ms":
        return RunSpec(trial.learner, observation_delay_fidelity(float(value)), **common), None
    if kind == "rigs":
        return RunSpec(trial.learner, "realistic", **common), RigParams.load(value)
    return RunSpec(trial.learner, str(value), **common), None


def where_am_i() -> dict:
    """The host, process, its niceness (None where the OS has none) and (under Ray) node a trial ran on."""
    node = None
    try:
        import ray

        if ray.is_initialized():
            node = ray.get_runtime_context().get_node_id()
    except ImportError:
        pass
    niceness = os.nice(0) if hasattr(os, "nice") else None
    return {"host": socket.gethostname(), "pid": os.getpid(), "niceness": niceness, "node_id": node}


def run_trial(trial: Trial, folder: str | Path) -> dict:
    """Run (or resume) `trial` in `folder`; return its result row (also written to result.json)."""
    import torch

    from pendkit.agents.policy_rule import REPORT_SEED, judge_policy, train_until_solved
    from pendkit.agents.runs import build_run, make_env, save_weights

    folder = Path(folder)
    if (folder / RESULT).exists():
        return json.loads((folder / RESULT).read_text())
    folder.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(1)  # one trial per CPU: threads would fight over the same cores
    spec, params = run_spec_and_params(trial)
    env = make_env(spec, params=params)
    _, agent, inputs = build_run(spec, env)
    probe = make_env(spec, params=params)
    _, _, probe_inputs = build_run(spec, probe)
    checks = _read_checks(folder / "checks.csv")
    spent_s = checks[-1]["wall_s"] if checks else 0.0
    resumed_from = checks[-1]["episodes"] if checks else 0
    solved_at: dict = {}

    def record(episodes: int, wall_s: float, verdict) -> None:
        _append_check(folder / "checks.csv", episodes, wall_s, verdict)
        if verdict.solved:
            solved_at["episodes"], solved_at["wall_s"] = episodes, wall_s

    started = time.perf_counter() - spent_s
    budget = trial.budget
    returns, _ = train_until_solved(env, agent, inputs, budget.max_episodes, budget.check_every, probe, probe_inputs,
                                    budget.max_wall_s, record, spent_s, seed=trial.seed, progress=False,
                                    csv_path=folder / "curve.csv", checkpoint_path=folder / "checkpoint.pt",
                                    checkpoint_every=budget.check_every, resume=True)
    if not solved_at and checks and checks[-1]["solved"]:  # solved just before a kill
        solved_at.update(episodes=checks[-1]["episodes"], wall_s=checks[-1]["wall_s"])
    held_out = judge_policy(probe, agent, probe_inputs, REPORT_SEED)
    save_weights(folder / "weights.pt", agent, spec if isinstance(spec.fidelity, str) else _named(spec),
                 {"trial": trial.trial_id})
    env.close()
    probe.close()
    result = {**trial.to_dict(), "solved": bool(solved_at), "episodes_to_solve": solved_at.get("episodes"),
              "wall_s_to_solve": round(solved_at["wall_s"], 1) if solved_at else None,
              "policy_solved": f"{held_out.held}/{len(held_out.starts)}", "held_out_solved": held_out.solved,
              "episodes": len(returns), "wall_s": round(time.perf_counter() - started, 1),
              "resumed_from_episode": resumed_from, "curve": f"trials/{folder.name}/curve.csv", **where_am_i()}
    write_text(folder / RESULT, json.dumps(result, indent=1) + "\n")  # atomic: a trial is finished or it is not
    return result


def _named(spec):
    """A spec on a custom Fidelity (the delay_ms sweeps) saved under the realistic preset's name: the
    weights load on any realistic env; the trial's own record says which latency it learned under."""
    import dataclasses

    return dataclasses.replace(spec, fidelity="realistic")


def _read_checks(path: Path) -> list[dict]:
    if not path.exists():
        return []
    with path.open() as handle:
        return [{"episodes": int(row["episodes"]), "wall_s": float(row["wall_s"]), "solved": row["solved"] == "1"}
                for row in csv.DictReader(handle)]


def _append_check(path: Path, episodes: int, wall_s: float, verdict) -> None:
    new = not path.exists()
    with path.open("a", newline="") as handle:
        writer = csv.writer(handle)
        if new:
            writer.writerow(["episodes", "wall_s", "solved", "screen_return", "held"])
        writer.writerow([episodes, f"{wall_s:.2f}", int(verdict.solved), f"{verdict.evaluation.returns[0]:.2f}",
                         f"{verdict.held}/{len(verdict.starts)}"])
