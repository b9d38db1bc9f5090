"""(c) the learned route within the laptop's time: each starting policy judged on the identified twin as shipped,
trained there for as long as the budget lets it, and judged again; the policies in parallel, one per core.

Each candidate is a job of its own (`judge_candidate`): its as-shipped verdict tells how long a verdict takes,
so its training stops in time for the last one before the deadline. A candidate with no time left to train
keeps its as-shipped verdict, and the report says what the budget cut.
"""

from __future__ import annotations

import copy
import dataclasses
import time
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from multiprocessing import get_context
from pathlib import Path

from pendkit.adapt.cost_pool import usable_cores
from pendkit.adapt.identify import Identification
from pendkit.adapt.progress import seconds_bar
from pendkit.adapt.routes import held_on_device, policy_observer, run_of_row, starting_weights, twin_env
from pendkit.agents.runs import build_run, save_weights
from pendkit.errors import ConfigError

# pendkit modules that load torch are imported inside the functions that use them (start-up; torch is optional)

JUDGE_TWIN_SEED_OFFSET = 1_000  # the twin's judge draws other rigs than its training
MIN_TRAIN_EPISODES = 3  # fewer are not worth a second verdict
# a trained verdict's time, guessed from the shipped one's with this slack, and the seconds after it for handing
# the rows back and writing the weights: on an idle machine the route ran 2 s past its budget without them
JUDGING_SLACK, WRAP_UP_S = 1.2, 5.0


def judge_candidate(name: str, identification: Identification, config, spread: dict | None,
                    deadline: float = float("inf")) -> list[dict]:
    """`name` as shipped and, time allowing (`deadline`: a `time.time()`), after up to `config.twin_episodes` on
    the identified twin: a row per stage with its verdicts (the kit's rule from the laptop, and run by the
    rig's own device) and its weights."""
    import torch

    from pendkit.agents.policy_rule import REPORT_SEED, judge_policy
    from pendkit.agents.train import train_sync

    torch.set_num_threads(1)  # one candidate per core
    spec, state = starting_weights(name)
    spec = dataclasses.replace(spec, randomize="", seed=config.seed)
    observer = policy_observer(spec, identification)
    env = twin_env(spec, identification, observer, spread, config.seed)
    judge = twin_env(spec, identification, observer, spread, config.seed + JUDGE_TWIN_SEED_OFFSET)
    _, agent, inputs = build_run(spec, env)
    agent.load_state_dict(state)
    rows = []

    def verdict(stage: str, trained: int, beat: dict | None = None) -> float:
        """Judge the agent as it is now; with `beat` (the as-shipped row), each check stops once it can no longer
        even tie that row's (a trained policy that cannot is never chosen over its shipped self)."""
        started = time.time()
        judged = judge_policy(judge, agent, inputs, seed=REPORT_SEED, need=beat["held"] if beat else None)
        device = held_on_device(identification, spec, agent, inputs, observer, REPORT_SEED,
                                need=(beat["held_on_device"] or 0) if beat else 0)
        rows.append({"policy": name, "stage": stage, "held": judged.held, "episodes": len(judged.starts),
                     "mean_return": judged.evaluation.mean_return, "held_on_device": device, "spec": spec,
                     "observer": observer, "state": copy.deepcopy(agent.state_dict()), "twin_episodes": trained,
                     "summary": judged.summary()})
        return time.time() - started

    try:
        judging_s = verdict("as shipped", 0)
        if config.twin_episodes:
            episode_started = [time.time()]
            episode_s = [0.0]

            def in_time(done: int, _returns) -> bool:
                now = time.time()
                episode_s[0] = max(episode_s[0], now - episode_started[0])
                episode_started[0] = now
                return now + episode_s[0] + judging_s * JUDGING_SLACK < deadline - WRAP_UP_S

            if time.time() + judging_s * (JUDGING_SLACK + MIN_TRAIN_EPISODES / 10) < deadline - WRAP_UP_S:
                returns = train_sync(env, agent, config.twin_episodes, inputs, seed=config.seed, progress=False,
                                     on_episode=in_time)
                if len(returns) >= MIN_TRAIN_EPISODES or len(returns) == config.twin_episodes:
                    verdict("trained", len(returns), beat=rows[0])
    finally:
        env.close()
        judge.close()
    return rows


def choose_on_twin(identification: Identification, config, weights_path: Path, say: Callable[[str], None],
                   spread: dict | None = None, deadline: float = float("inf"), workers: int | None = None):
    """(c) with candidates: `config.policy` and each of `config.candidates` (shipped policies), as shipped and
    after the twin's training (as much as `deadline` allows), judged there by the kit's rule (its 10 starts,
    on rigs drawn from `spread` when given); the one that holds most (then the highest mean return; as
    shipped before trained, the first named before the others on a tie) goes on to the rig. Each is also
    judged as the rig's device would run it (`held_on_device`), and the one that holds most there is the
    device's. Returns the laptop's run, every candidate's verdicts, and the device's run (None when the device
    runs none of them)."""
    names = list(dict.fromkeys((config.policy, *config.candidates)))
    for name in names:
        if starting_weights(name)[1] is None:
            raise ConfigError(f"candidate {name!r} is not a shipped policy with weights here: candidates are judged "
                              "as shipped and after the twin's training (pendkit policies list)")
    jobs = min(usable_cores(workers), len(names))
    by_name = _run_jobs(names, identification, config, spread, deadline, jobs)
    judged = [row for name in names for row in by_name[name]]
    for row in judged:
        on_device = "" if row["held_on_device"] is None else f"; run by its device, {row['held_on_device']} of 10 held"
        trained = f" ({row['twin_episodes']} episodes)" if row["stage"] == "trained" else ""
        say(f"(c) {row['policy']} {row['stage']}{trained} on the identified twin: {row['summary']}{on_device}")
    best = max(judged, key=lambda row: (row["held"], row["mean_return"]))  # max keeps the first of equals
    run = run_of_row(best, identification, config)
    save_weights(weights_path, run.agent, best["spec"], {"identified_rig": identification.values(),
                                                         "chosen_on_twin": f"{best['policy']} {best['stage']}"})
    say(f"(c) chosen on the twin: {best['policy']} {best['stage']}")
    runnable = [row for row in judged if row["held_on_device"] is not None]
    device_best = max(runnable, key=lambda row: (row["held_on_device"], row["held"], row["mean_return"]), default=None)
    device_run = run if device_best is best else (None if device_best is None else
                                                 run_of_row(device_best, identification, config))
    if device_best is not None:
        say(f"(c) chosen for the rig's device: {device_best['policy']} {device_best['stage']}")
    keys = ("policy", "stage", "held", "episodes", "mean_return", "held_on_device", "twin_episodes")
    return run, [{key: row[key] for key in keys} for row in judged], device_run


def _run_jobs(names: list[str], identification, config, spread, deadline: float, jobs: int) -> dict[str, list[dict]]:
    """Each candidate's rows, `jobs` at a time (in this process for one), a bar over the seconds to `deadline`."""
    if jobs <= 1:
        return {name: judge_candidate(name, identification, config, spread, deadline) for name in names}
    # spawned: a forked torch (its thread pools) can hang in the child
    with ProcessPoolExecutor(jobs, mp_context=get_context("spawn")) as pool, \
            seconds_bar("(c) learned route", deadline) as bar:
        futures = {pool.submit(judge_candidate, name, identification, config, spread, deadline): name
                   for name in names}
        pending, done = set(futures), {}
        while pending:
            finished, pending = wait(pending, timeout=1.0, return_when=FIRST_COMPLETED)
            for future in finished:
                done[futures[future]] = future.result()
            bar.tick(f"{len(done)} of {len(names)} policies judged")
    return done
