"""How `pendkit adapt` should choose among its device designs: trial rules compared on recorded episodes.

    python benchmarks/bench_transfer.py adapt --rigs 6 --seeds 1 2 --out runs/adapt   # identifications
    python benchmarks/bench_trial_rules.py runs/adapt [--episodes 10] [--draws 400] [--jobs 2]

For each finished adaptation in DIR (its `rig.json`, the identified twin, and the hidden rig it was run on,
named as `bench_transfer.py` names them, its encoder recalibrated as the adaptation did), every candidate
design of `pendkit.adapt.trials` is made on the identified twin and run `--episodes` whole episodes on the
rig's device from rest (saved beside the run as `trial-episodes.npz`, reused). Each rule is then replayed
`--draws` times on those episodes, a trial taking an unused episode (a shorter trial its first steps), and
scored by how often the design it chose solves the episodes its trials did not use. Lines: one per run, then
per rule the mean solved fraction, the expected rigs solved 3/3 (sum of p^3) and its rig time.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

import numpy as np

from pendkit.adapt.trials import CONTROLLERS, LOOP_VARIANTS, trial_steps
from pendkit.agents.runs import SOLVED_TAIL_STEPS, held_fraction
from pendkit.env_name import EPISODE_STEPS
from pendkit.features import holds_upright

OLD_STEPS, OLD_CONFIRMED = 150, 2  # the rule shipped before: 150-step trials, the best two once more


def recorded_episodes(run_dir: Path, episodes: int) -> dict[str, list[np.ndarray]]:
    """Every candidate design's whole episodes on the hidden rig, keyed "controller/label"."""
    import torch

    torch.set_num_threads(1)
    from bench_transfer import adapt_rigs

    from pendkit.adapt.rigs import twin_rig
    from pendkit.adapt.trials import make_designs
    from pendkit.rig import RigParams

    saved = run_dir / "trial-episodes.npz"
    if saved.exists():
        with np.load(saved) as data:
            return {key.replace("|", "/"): list(data[key]) for key in data.files}
    hidden = dict(adapt_rigs(6))[run_dir.name.split("-full")[0]]
    report = json.loads((run_dir / "report.json").read_text()) if (run_dir / "report.json").exists() else {}
    runs = {}
    for design in make_designs(RigParams.load(run_dir / "rig.json"), say=lambda _: None):
        if design.blob is not None:
            rig = twin_rig(hidden.params, hidden.network, hidden.residual_offset_counts)  # same seeds per design
            rig.recalibrate(report.get("encoder_recalibrated_counts", 0))  # as the adaptation left the rig
            runs[f"{design.controller}/{design.label}"] = [np.asarray(a) for a in rig.run_on_device(design.blob,
                                                                                                      episodes)]
    np.savez(saved, **{key.replace("/", "|"): np.stack(value) for key, value in runs.items()})
    return runs


class Replay:
    """A stand-in `run_on_device` serving each design's recorded episodes, each at most once per draw."""

    def __init__(self, episodes: dict, blobs: dict, rng) -> None:
        self.episodes, self.blobs = episodes, blobs
        self.unused = {key: list(rng.permutation(len(value))) for key, value in episodes.items()}

    def __call__(self, blob: bytes, count: int, steps: int) -> list[list[float]]:
        key = self.blobs[blob]
        return [list(self.episodes[key][self.unused[key].pop()][:steps + 1]) for _ in range(count)]


def old_rule(designs, replay):
    """150-step trials judged on their last 100 steps, the best two once more, the better worse trial."""
    from pendkit.adapt.trials import trial_score

    for design in designs:
        design.trials += replay(design.blob, 1, OLD_STEPS)
    worst = lambda d: min(trial_score(a) for a in d.trials)  # noqa: E731
    finalists = sorted(designs, key=worst, reverse=True)[:OLD_CONFIRMED]
    for design in finalists:
        design.trials += replay(design.blob, 1, OLD_STEPS)
    return max(finalists, key=worst)


def identified_only(each: int):
    """The identified twin's two designs, `each` whole episodes each: no loop variants."""
    def rule(designs, replay):
        mine = [d for d in designs if d.label == "identified"]
        for design in mine:
            design.trials += replay(design.blob, each, EPISODE_STEPS)
        return max(mine, key=lambda d: (sum(holds_upright(a, SOLVED_TAIL_STEPS) for a in d.trials),
                                        min(held_fraction(a) or 0.0 for a in d.trials)))
    return rule


def identified_plan(designs, replay):
    """No trials: the identified twin's minimum-time design."""
    return next(d for d in designs if d.label == "identified" and d.controller == "trajopt")


def screened(**changes):
    """The shipped rule (`pendkit.adapt.trials.run_trials`), with `changes` to its screen_steps or finalists."""
    from pendkit.adapt.trials import run_trials

    return lambda designs, replay: run_trials(designs, replay, say=lambda _: None, **changes)


DESIGNS = len(LOOP_VARIANTS) * len(CONTROLLERS)
WHOLE = EPISODE_STEPS + 1  # a whole episode's rig steps, its reset included
# name: (rule, rig steps it takes at most)
RULES = {"shipped: screen 200, best 3 whole": (screened(), trial_steps()),
         "before: 150 x 12": (old_rule, (DESIGNS + OLD_CONFIRMED) * (OLD_STEPS + 1)),
         "identified only, 2 whole each": (identified_only(2), 4 * WHOLE),
         "identified only, 1 whole each": (identified_only(1), 2 * WHOLE),
         "identified min-time, no trials": (identified_plan, 0),
         "screen 150, best 2 whole": (screened(screen_steps=150, finalists=2), DESIGNS * 151 + 2 * WHOLE),
         "screen 150, best 3 whole": (screened(screen_steps=150, finalists=3), DESIGNS * 151 + 3 * WHOLE),
         "screen 150, best 4 whole": (screened(screen_steps=150, finalists=4), DESIGNS * 151 + 4 * WHOLE)}


def score_rules(run_dir: Path, episodes: dict, draws: int) -> dict[str, float]:
    from pendkit.adapt.trials import make_designs
    from pendkit.rig import RigParams

    made = [d for d in make_designs(RigParams.load(run_dir / "rig.json"), say=lambda _: None) if d.blob]
    blobs = {d.blob: f"{d.controller}/{d.label}" for d in made}
    rng, scores = np.random.default_rng(0), {}
    for name, (rule, _) in RULES.items():
        got = []
        for _ in range(draws):
            replay = Replay(episodes, blobs, rng)
            chosen = rule([dataclasses.replace(d, trials=[]) for d in made], replay)
            key = blobs[chosen.blob]
            got.append(np.mean([holds_upright(episodes[key][i], SOLVED_TAIL_STEPS) for i in replay.unused[key]]))
        scores[name] = float(np.mean(got))
    return scores


def one_run(run_dir: str, episodes: int, draws: int) -> tuple[str, dict, dict]:
    recorded = recorded_episodes(Path(run_dir), episodes)
    solved = {key: float(np.mean([holds_upright(a, SOLVED_TAIL_STEPS) for a in runs]))
              for key, runs in recorded.items()}
    return Path(run_dir).name, solved, score_rules(Path(run_dir), recorded, draws)


def main() -> None:
    from concurrent.futures import ProcessPoolExecutor

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("runs", type=Path)
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--draws", type=int, default=400)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    dirs = sorted(str(d) for d in args.runs.glob("hidden-*-full-s*") if (d / "rig.json").exists())
    totals = {name: [] for name in RULES}
    with ProcessPoolExecutor(args.jobs) as pool:
        for name, solved, scores in pool.map(one_run, dirs, [args.episodes] * len(dirs), [args.draws] * len(dirs)):
            best = max(solved, key=solved.get)
            print(f"run={name} best={best}:{solved[best]:.2f} identified energy/trajopt="
                  f"{solved.get('energy/identified', 0):.2f}/{solved.get('trajopt/identified', 0):.2f} "
                  + " ".join(f"[{rule}]={p:.2f}" for rule, p in scores.items()), flush=True)
            for rule, p in scores.items():
                totals[rule].append(p)
    for (rule, ps), (_, steps) in zip(totals.items(), RULES.values()):
        print(f"rule={rule!r} runs={len(ps)} mean_solved={np.mean(ps):.2f} "
              f"expected_3of3={np.sum(np.asarray(ps) ** 3):.1f} rig_s={steps * 0.06:.0f}")


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py (here: tests load this file alone)

    print_header()
    main()
