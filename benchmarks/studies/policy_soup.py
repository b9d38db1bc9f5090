"""Study: do weight-averaged fine-tunes of one policy (a "model soup") hold more rigs on the rig's device?

    python benchmarks/studies/policy_soup.py W1.pt W2.pt ... [--with-shipped] [--greedy] [--unseen] [--laptop]

Every ingredient must be a fine-tune of the same start (e.g. `robust_observer.py --start-from r-td3-bank-robust
--out W.pt`): the networks' weights and the input normaliser's statistics are averaged. Scored as a blob on the
devices of the 12 validation rigs (rest + 5 random starts, 72 episodes; `--validation-rigs N --fresh-validation`:
N others, drawn after the 12 the ingredients' checkpoints were kept by); `--greedy` adds the ingredients one at
a time, best-scored first, keeping each that does not lower the score; `--unseen` judges the result once on the
devices of the presets and held-out rigs (90 episodes), `--laptop` from the laptop too. Results:
docs/results/robust.md.
"""

from __future__ import annotations

import argparse
import copy

import numpy as np


def soup(states: list[dict]) -> dict:
    """The mean of the states' networks; the normaliser's mean and variance averaged (its count the first's)."""
    out = copy.deepcopy(states[0])
    for key in out["net"]:
        out["net"][key] = sum(s["net"][key].float() for s in states) / len(states)
    count = states[0]["normalizer"]["count"]
    mean = np.mean([np.asarray(s["normalizer"]["mean"], dtype=np.float64) for s in states], axis=0)
    variance = np.mean([np.asarray(s["normalizer"]["m2"], dtype=np.float64) / s["normalizer"]["count"]
                        for s in states], axis=0)
    dtype = np.asarray(states[0]["normalizer"]["mean"]).dtype
    out["normalizer"] = {"count": count, "mean": mean.astype(dtype), "m2": (variance * count).astype(dtype)}
    return out


def held_on_devices(spec, state: dict, rigs: dict) -> int:
    """Episodes the state's blob holds on the rigs' devices (rest + 5 random starts each)."""
    from pendkit.agents.rig_suite import summary
    from pendkit.agents.threads import use_kit_threads
    from pendkit.deploy.on_twin import policy_on_devices

    use_kit_threads()
    return summary(policy_on_devices(spec, state, rigs))["solved"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("weights", nargs="+", help="fine-tunes of one policy (the kit's weights format)")
    parser.add_argument("--with-shipped", action="store_true", help="r-td3-bank-robust as shipped is an ingredient")
    parser.add_argument("--greedy", action="store_true")
    parser.add_argument("--unseen", action="store_true")
    parser.add_argument("--laptop", action="store_true")
    parser.add_argument("--validation-rigs", type=int, default=12)
    parser.add_argument("--fresh-validation", action="store_true",
                        help="validation rigs after the 12 the fine-tunes' checkpoints were kept by")
    parser.add_argument("--jobs", type=int, default=1, help="processes ranking the ingredients one by one")
    args = parser.parse_args()

    from concurrent.futures import ProcessPoolExecutor

    from pendkit.agents.pretrained import policy_weights
    from pendkit.agents.rig_suite import policy_on_rigs, preset_rigs, random_rigs, summary, validation_rigs
    from pendkit.agents.runs import load_weights
    from pendkit.deploy.on_twin import policy_on_devices
    from pendkit.rig import RigParams
    from pendkit.sim.randomize import RandomRig

    spec, shipped = policy_weights("r-td3-bank-robust")
    ingredients = {path: load_weights(path)[1] for path in args.weights}
    if args.with_shipped:
        ingredients = {"shipped": shipped, **ingredients}
    checking = validation_rigs(args.validation_rigs, after=12 if args.fresh_validation else 0)
    episodes = 6 * len(checking)

    def validation(names: list[str]) -> int:
        held = held_on_devices(spec, soup([ingredients[n] for n in names]), checking)
        print(f"soup {'+'.join(names)}: device validation {held}/{episodes}", flush=True)
        return held

    chosen = list(ingredients)
    if args.greedy:
        with ProcessPoolExecutor(args.jobs) as pool:
            alone = dict(zip(ingredients, pool.map(held_on_devices, [spec] * len(ingredients),
                                                   list(ingredients.values()), [checking] * len(ingredients))))
        for name, held in alone.items():
            print(f"alone {name}: device validation {held}/{episodes}", flush=True)
        ranked = sorted(ingredients, key=lambda name: -alone[name])
        chosen, best = ranked[:1], alone[ranked[0]]
        for name in ranked[1:]:
            held = validation(chosen + [name])
            if held >= best:
                chosen, best = chosen + [name], held
        print(f"greedy soup: {'+'.join(chosen)} at {best}/{episodes}", flush=True)
    else:
        validation(chosen)
    state = soup([ingredients[n] for n in chosen])
    rigs = {**preset_rigs(), **random_rigs(10)}
    if args.unseen:
        out = policy_on_devices(spec, state, rigs)
        print(f"soup {'+'.join(chosen)}: device, presets + held-out {summary(out)['solved']}/90 "
              + " ".join(f"{name}={sum(e.solved)}/{len(e.solved)}" for name, e in out.items()), flush=True)
    if args.laptop:
        default = summary(policy_on_rigs(spec, state, {"default": RandomRig(RigParams(), None, 0)}, starts=20))
        out = policy_on_rigs(spec, state, rigs, starts=5)
        print(f"soup {'+'.join(chosen)}: laptop, default {default['solved']}/21, presets + held-out "
              f"{summary(out)['solved']}/90")


if __name__ == "__main__":
    main()
