"""`pendkit eval --controller energy|trajopt`: a classical swing-up run from the laptop on the twin or a rig,
judged by the kit's rule (the `eval` command itself lives in `pendkit.cli.learning`)."""

from __future__ import annotations

from pathlib import Path

import click


def evaluate_controller(name: str, episodes: int, backend: str, rig_id: str, broker: str | None,
                        preset: str | None, params_path: Path | None, start: str, seed: int | None, login) -> None:
    """Print the rule, each episode's outcome, the verdict (`controller: controller_solved=K/10 (yes|no)`) and the
    summary line `solved=K/N median_upright_s=X`."""
    from pendkit.agents.policy_rule import REPORT_SEED, RULE_STARTS, RULE_TEXT
    from pendkit.control.judge import controller_env, judge_controller, rule_verdict
    from pendkit.rig import RigParams

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
