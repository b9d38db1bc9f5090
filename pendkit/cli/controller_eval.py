"""`pendkit eval --controller NAME`: a classical swing-up (energy pumping + LQR, or the minimum-time
plan) run from the laptop on the twin or a rig, judged by the kit's rule as a learned policy is (the `eval`
command itself lives in `pendkit.cli.learning`). The controller is designed for the env it runs on (its step,
delays and servo), as the demo does; on a rig that is the rig's parameters (`--params` or a preset) behind
the assumed network latency."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import click

from pendkit.deploy.controllers import controller_named
from pendkit.rig import RigParams

# pendkit modules that load torch and MuJoCo are imported inside the functions that use them: importing this module
# does not need them (`pendkit --help` stays quick).


def evaluate_controller(name: str, episodes: int, backend: str, rig_id: str, broker: str | None,
                        preset: str | None, params_path: Path | None, start: str, seed: int | None, login) -> None:
    """Print the rule, each episode's outcome, the verdict (`controller: controller_solved=K/10 (yes|no)`) and the
    summary line `solved=K/N median_upright_s=X`."""
    from pendkit.agents.policy_rule import REPORT_SEED, RULE_STARTS, RULE_TEXT

    if preset is not None and params_path is not None:
        raise click.UsageError("give --preset or --params, not both")
    params = (RigParams.load(params_path) if params_path is not None
              else RigParams.preset(preset) if preset is not None else RigParams())
    on_rig = backend == "rig"
    if on_rig:
        starts = [None] * episodes  # a rig starts as it is: hanging still after the reset's wait
    elif start == "rule":
        starts = [RULE_STARTS[k % len(RULE_STARTS)] for k in range(episodes)]
    else:
        starts = [start] * episodes
    seed = REPORT_SEED if seed is None else seed
    env = controller_env(params, backend, rig_id, broker, login.rig_options() or None)
    where = f"rig {rig_id}" if on_rig else "the realistic twin"
    click.echo(f"{name} swing-up designed for {params.servo_name} on {where}, {episodes} episodes")
    try:
        outcome = judge_controller(env, name, starts, seed, say=click.echo)
    finally:
        env.close()
    click.echo(f"mean return {outcome.mean_return:.1f} over {episodes} episodes")
    click.echo(f"rule: {RULE_TEXT}" + (" (on a rig every episode starts hanging still)" if on_rig else ""))
    verdict = rule_verdict(outcome, starts, seed) if on_rig or start == "rule" else None
    if verdict is None:
        click.echo(f"controller: not judged (the rule takes at least {len(RULE_STARTS)} episodes"
                   + ("" if on_rig else " of --start rule") + ")")
    else:
        shown = " ".join(f"{k}={v}" for k, v in verdict.held_by_start().items())
        click.echo(f"controller: {verdict.summary('controller')}" + (f" {shown}" if shown else ""))
    click.echo(outcome.summary())


def controller_env(params: RigParams, backend: str = "sim", rig: str = "r01", broker: str | None = None,
                   rig_options: dict | None = None):
    """The env a classical controller runs on: continuous actions, no env filter (the controller smooths its own
    targets); the realistic twin, or the rig over MQTT."""
    import pendkit

    options = {"backend": "rig", "rig": rig, "broker": broker, "rig_options": rig_options} if backend == "rig" else {}
    return pendkit.make(action_mode="continuous", filter_coefficient=0.0, fidelity="realistic", params=params,
                        **options)


def judge_controller(env, name: str, starts: list[str | None], seed: int,
                     say: Callable[[str], None] | None = None):
    """One episode per entry of `starts` (None: as the env starts, e.g. a rig hanging still), episode k from
    seed `seed + k`; each judged by the rule's tail (held within 0.3 rad of upright for its last 200 steps)."""
    from pendkit.agents.runs import judge_runs

    def said(k: int, start: str | None, one) -> None:
        where = f"from {start}" if start else "from rest"
        shown = f"held, upright after {one.upright_s[0]:.2f} s" if one.solved[0] else "not held"
        say(f"episode {k + 1}/{len(starts)} {where}: {shown}")

    return judge_runs(env, controller_named(name).host(env), starts, seed, said if say is not None else None)


def rule_verdict(outcome, starts: list[str | None], seed: int):
    """The rule's verdict (a `PolicyVerdict`) over the first ten episodes when they are the rule's starts (or a
    rig's, all from rest); None when fewer were run."""
    from pendkit.agents.policy_rule import RULE_STARTS, PolicyVerdict
    from pendkit.agents.runs import Evaluation

    if len(starts) < len(RULE_STARTS):
        return None
    first = Evaluation(*(getattr(outcome, name)[:len(RULE_STARTS)]
                         for name in ("solved", "upright_s", "returns", "held_fractions")))
    return PolicyVerdict(first, tuple(starts[:len(RULE_STARTS)]), seed)
