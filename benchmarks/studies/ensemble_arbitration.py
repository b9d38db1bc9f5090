"""Study: do two robust R-TD3 policies (trained alike, other seeds) hold more unseen rigs together than either
alone, each step taking the action the pair's critics value most?

    python benchmarks/studies/ensemble_arbitration.py A.pt B.pt [--starts 5]

Each member runs its own GRU on the same inputs and proposes an action; every member's critic (the smaller of
its twin critics) scores every proposal, and the proposal with the highest mean score is sent; with
`--margin M` the member in charge keeps it until another's proposal scores M more (a pair that switches
every step can lose a rig both members hold alone). Choose M on `--rigs validation` (the training ranges'
validation rigs, rest + `--starts` random starts each), then judge once on the unseen rigs. Judged as
`robust_observer.py` judges one policy: the default rig (rest + 20 random starts) and the 5 presets + 10
held-out rigs (rest + `--starts` random starts each). Results: docs/results/robust.md.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
import torch


class CriticArbitration:
    """Greedy-only agent over recurrent actor-critic members (`RecurrentTd3Agent`) that read the same inputs."""

    def __init__(self, members: list, margin: float = 0.0) -> None:
        self.members, self.margin, self.in_charge = members, margin, 0
        self.config = members[0].config
        self.chosen = np.zeros(len(members), dtype=int)  # how often each member's proposal was sent

    def reset(self) -> None:
        self.in_charge = 0
        for member in self.members:
            member.reset()

    def track_input(self, x) -> None:  # never learns
        pass

    def act(self, x, explore: bool = False) -> np.ndarray:
        features, proposals = [], []
        with torch.no_grad():
            for member in self.members:
                z = member.normalizer.normalize(torch.as_tensor(np.asarray(x, dtype=np.float32)).reshape(1, -1))
                member.hidden = member.net.trunk.step(z, member.hidden)
                feature = torch.cat([z, member.hidden], dim=-1)
                features.append(feature)
                proposals.append(member.net.actor(feature))
            scores = [np.mean([float(torch.min(*member.net.q(feature, proposal)))
                               for member, feature in zip(self.members, features)]) for proposal in proposals]
        best = int(np.argmax(scores))
        if scores[best] < scores[self.in_charge] + self.margin:
            best = self.in_charge
        self.in_charge = best
        self.chosen[best] += 1
        return np.clip(proposals[best][0].numpy(), -1.0, 1.0).astype(np.float32)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("weights", nargs="+", help="weights files of the members (one learner, one observer)")
    parser.add_argument("--starts", type=int, default=5)
    parser.add_argument("--margin", type=float, default=0.0)
    parser.add_argument("--rigs", choices=["unseen", "validation"], default="unseen")
    args = parser.parse_args()
    from pendkit.agents.rig_suite import preset_rigs, random_rigs, rig_env, summary, validation_rigs
    from pendkit.agents.runs import Evaluation, build_run, evaluate_agent, load_weights
    from pendkit.agents.threads import use_kit_threads
    from pendkit.rig import RigParams
    from pendkit.sim.randomize import RandomRig

    use_kit_threads()
    loaded = [load_weights(path) for path in args.weights]
    spec = loaded[0][0]
    if any(other.learner != spec.learner or other.observer != spec.observer for other, _ in loaded):
        raise SystemExit("members must share a learner and an observer (they read the same inputs)")
    started = time.monotonic()

    def on_rigs(rigs: dict, starts: int) -> dict[str, Evaluation]:
        outcomes = {}
        for name, rig in rigs.items():
            env = rig_env(rig, spec)
            members = []
            for _, state in loaded:
                _, agent, inputs = build_run(spec, env)
                agent.load_state_dict(state)
                members.append(agent)
            pair = CriticArbitration(members, args.margin)
            outcomes[name] = evaluate_agent(env, pair, inputs, 1 + starts, 10_000, ["rest"] + ["random"] * starts)
            print(f"{name}: {sum(outcomes[name].solved)}/{1 + starts} (proposals sent: {pair.chosen.tolist()})",
                  flush=True)
            env.close()
        return outcomes

    if args.rigs == "validation":
        checked = on_rigs(validation_rigs(), args.starts)
        print(json.dumps({"members": args.weights, "margin": args.margin, "validation": summary(checked)}))
        return
    default = summary(on_rigs({"default": RandomRig(RigParams(), None, 0)}, 20))
    unseen = on_rigs({**preset_rigs(), **random_rigs(10)}, args.starts)
    print(json.dumps({"members": args.weights, "margin": args.margin, "default_rig": default,
                      "presets_and_held_out": summary(unseen),
                      "per_rig": {name: sum(e.solved) for name, e in unseen.items()},
                      "wall_s": round(time.monotonic() - started)}, indent=1))


if __name__ == "__main__":
    main()
