"""A sweep's trials as Ray Tune trials: local by default (one CPU per trial), or on an existing Ray cluster
(`address="auto"`, or `ray://host:10001` through Ray Client). Ray only schedules; each trial keeps its
state in its own folder (`pendkit.sweep.trial`), so `resume=True` skips finished trials and continues the
others from their last checkpoint, whether the sweep was stopped by Ctrl-C, a kill or a lost node.

On a cluster every node needs pendkit installed. Where DIR is a folder every node sees (a shared
filesystem), a trial resumes on any node; where it is not, each trial's files stay on the node that ran it
and the driver writes the trial's result row into its own DIR, so the table is whole either way.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

from pendkit.errors import ConfigError
from pendkit.safe_write import write_text
from pendkit.sweep.spec import SweepSpec, Trial
from pendkit.sweep.trial import RESULT, run_trial

SPEC_COPY = "spec.json"
STARTS = 2  # a local Ray's start-ups before giving up (a laptop busy with other work can miss Ray's 30 s)


def ray_or_exit():
    try:
        import ray
        from ray import tune
    except ImportError:
        raise ConfigError('`pendkit sweep` runs on Ray Tune: pip install -e ".[cluster]"') from None
    return ray, tune


def prepare_folder(spec: SweepSpec, out: Path, resume: bool) -> list[Trial]:
    """Check DIR against `resume`, record the spec there, and return the trials still to run."""
    copy = out / SPEC_COPY
    if copy.exists() and not resume:
        raise ConfigError(f"{out} already holds a sweep: add --resume to continue it, or choose another --out")
    if not copy.exists() and out.is_dir() and any(out.iterdir()):
        raise ConfigError(f"{out} holds files but no sweep: give an empty or new folder as --out (a sweep writes "
                          "table.csv, trials/ and more there)")
    if out.exists() and not out.is_dir():
        raise ConfigError(f"{out} is a file: --out is a folder")
    if copy.exists():
        try:
            recorded = json.loads(copy.read_text())["trials"]
        except (ValueError, KeyError, TypeError):
            raise ConfigError(f"{copy} is not a sweep's record: choose another --out") from None
        if recorded != [t.to_dict() for t in spec.trials]:
            raise ConfigError(f"{out} holds another sweep than this spec's; resume it with its own spec, or "
                              "choose another --out")
    out.mkdir(parents=True, exist_ok=True)
    write_text(copy, json.dumps({"name": spec.name, "source": spec.source,
                                 "trials": [t.to_dict() for t in spec.trials]}, indent=1) + "\n")
    return [t for t in spec.trials if not (out / "trials" / t.trial_id / RESULT).exists()]


def start_ray(address: str | None = None, num_cpus: int | None = None, say=print) -> float:
    """Start a local Ray (`num_cpus`, all by default) or join the cluster at `address`; its start-up seconds."""
    ray, _ = ray_or_exit()
    os.environ.setdefault("TUNE_DISABLE_AUTO_CALLBACK_LOGGERS", "1")  # no TensorBoard/CSV files of Tune's own
    os.environ.setdefault("RAY_AIR_NEW_OUTPUT", "0")
    started = time.perf_counter()
    # Ray starts its workers at niceness 15, so on a laptop in use (or beside a test run) a local sweep's trials
    # get a few percent of a core; here they are the work, so they run at the driver's own priority. A
    # cluster's nodes keep what `ray start` gave them (RAY_worker_niceness=0 there does the same).
    local = {"num_cpus": num_cpus, "_system_config": {"worker_niceness": 0}} if address is None else {}
    for attempt in range(1, STARTS + 1):
        try:
            ray.init(address=address or "local", **local, include_dashboard=False, log_to_driver=False,
                     configure_logging=True, logging_level="ERROR", ignore_reinit_error=True)
            break
        except Exception as error:  # Ray raises a bare Exception when its node misses its fixed 30 s to start
            if address is not None or attempt == STARTS or "timed out during startup" not in str(error):
                raise
            say("Ray's local node did not start within Ray's 30 s (a busy machine): starting it once more")
            ray.shutdown()
    ray_start_s = time.perf_counter() - started
    nodes = [n for n in ray.nodes() if n.get("Alive")]
    say(f"Ray up in {ray_start_s:.1f} s: {len(nodes)} node(s), {ray.cluster_resources().get('CPU', 0):g} CPUs")
    return ray_start_s


def map_on_ray(function, calls: list[tuple], address: str | None = None, num_cpus: int | None = None,
               say=print):
    """`function(*call)` for every call as a one-CPU Ray task; yields the results in order as they come
    (the benchmarks' work that is not a learning trial, such as adapting to rigs)."""
    ray, _ = ray_or_exit()
    start_ray(address, num_cpus, say)
    remote = ray.remote(num_cpus=1)(function)
    try:
        for ref in [remote.remote(*call) for call in calls]:
            yield ray.get(ref)
    finally:
        ray.shutdown()


def _trial_name(ray_trial) -> str:
    return ray_trial.config["trial"]["trial_id"]


def _trainable(config: dict) -> None:
    from ray import tune

    trial = Trial.from_dict(config["trial"])
    result = run_trial(trial, Path(config["out"]) / "trials" / trial.trial_id)
    tune.report({"solved": int(result["solved"]), "episodes": result["episodes"], "wall_s": result["wall_s"],
                 "row": json.dumps(result)})  # the driver keeps the row even where nodes share no disk


def run_sweep(spec: SweepSpec, out: str | Path, address: str | None = None, resume: bool = False,
              cpus_per_trial: float = 1.0, say=print, num_cpus: int | None = None) -> dict:
    """Run the spec's unfinished trials through Ray Tune (a local Ray of `num_cpus`, all by default, or the
    cluster at `address`); returns {"ran", "skipped", "ray_start_s"}."""
    out = Path(out).resolve()
    pending = prepare_folder(spec, out, resume)
    skipped = len(spec.trials) - len(pending)
    if skipped:
        say(f"{skipped} of {len(spec.trials)} trials already finished in {out}: not run again")
    if not pending:
        return {"ran": 0, "skipped": skipped, "ray_start_s": 0.0}
    ray, tune = ray_or_exit()
    ray_start_s = start_ray(address, num_cpus, say)
    say(f"{len(pending)} trials, {cpus_per_trial:g} CPU each")
    lines = trial_lines_callback(out, say, len(pending))
    try:
        tuner = tune.Tuner(
            tune.with_resources(_trainable, {"cpu": cpus_per_trial}),
            param_space={"trial": tune.grid_search([t.to_dict() for t in pending]), "out": str(out)},
            tune_config=tune.TuneConfig(reuse_actors=False, trial_name_creator=_trial_name,
                                        trial_dirname_creator=_trial_name),
            run_config=tune.RunConfig(storage_path=str(out / "ray"), name=spec.name, verbose=0,
                                      callbacks=[lines],
                                      failure_config=tune.FailureConfig(max_failures=2)))
        results = tuner.fit()
        errors = [r.error for r in results if r.error is not None]
    finally:
        lines.bar.close()
        ray.shutdown()
    if errors:
        raise RuntimeError(f"{len(errors)} trials failed; the first: {errors[0]}")
    return {"ran": len(pending), "skipped": skipped, "ray_start_s": ray_start_s}


def trial_lines_callback(out: Path, say, total: int):
    """A tune.Callback: a line per finished trial as it finishes, under a progress bar of the trials (its
    class is made here, once Ray is imported, so that Ray stays optional)."""
    from ray import tune
    from tqdm.auto import tqdm

    class TrialLines(tune.Callback):
        bar = tqdm(total=total, desc="trials", unit="trial")

        def on_trial_complete(self, iteration, trials, trial, **info):
            self.bar.update(1)
            trial_id = trial.config["trial"]["trial_id"]
            path = out / "trials" / trial_id / RESULT
            row = (trial.last_result or {}).get("row")
            if not path.exists() and row:  # run on a node that does not share DIR: its row, not its files
                write_text(path, row + "\n", base=out)
            if path.exists():  # above the bar, not through it
                self.bar.clear()
                say(trial_line(json.loads(path.read_text())))
                self.bar.refresh()

    return TrialLines()


def trial_line(row: dict) -> str:
    episodes = row["episodes_to_solve"] if row["solved"] else "-"
    return (f"trial={row['trial_id']} learner={row['learner']} setting={row['setting_name']} seed={row['seed']} "
            f"solved={row['solved']} episodes_to_solve={episodes} policy_solved={row.get('policy_solved', '-')} "
            f"episodes={row['episodes']} "
            f"wall_s={row['wall_s']:.1f} host={row.get('host', '-')} node={str(row.get('node_id') or '-')[:8]}")
