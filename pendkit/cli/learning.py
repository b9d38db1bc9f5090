"""`pendkit train`, `eval`, `plot`, `policies`: learners on the twin or a rig. Torch is imported only when a
command runs, so the rest of pendkit works without the rl extra. Runs are built, saved and loaded through
`pendkit.agents.runs`, as the shipped policies and the benchmarks are."""

from __future__ import annotations

import json
from pathlib import Path

import click

from pendkit.agents.async_trainer import AsyncTrainer
from pendkit.agents.learners import LEARNER_NAMES
from pendkit.cli.broker_login import broker_login_options, login_from
from pendkit.cli.controller_eval import evaluate_controller
from pendkit.deploy.controllers import CONTROLLER_NAMES
from pendkit.episode import PALETTE
from pendkit.errors import ConfigError
from pendkit.link import DEFAULT_BROKER
from pendkit.rig import SERVO_PRESETS, RigParams
from pendkit.sim.fidelity import FIDELITY_PRESETS
from pendkit.sim.randomize import parse_randomize

# pendkit modules that load torch and MuJoCo are imported inside the functions that use them: importing this module
# does not need them (`pendkit --help` stays quick).

FIDELITIES = tuple(FIDELITY_PRESETS)


def _algorithms() -> tuple[str, ...]:
    return LEARNER_NAMES


def torch_or_exit() -> None:
    try:
        import torch  # noqa: F401
    except ImportError:
        raise click.ClickException('the RL commands need PyTorch: pip install -e ".[rl]" (install the CPU build '
                                   "of torch first, see the README)") from None


def _check_randomize(ctx, param, value: str) -> str:
    try:
        return ",".join(parse_randomize(value or ""))
    except ConfigError as error:
        raise click.BadParameter(str(error)) from None


def _preset_names() -> list[str]:
    return sorted(SERVO_PRESETS)


@click.command()
@click.option("--algo", type=click.Choice(_algorithms()), default="dqn", show_default=True,
              help="The learner: an algorithm and what it sees (docs/rl.md).")
@click.option("--fidelity", type=click.Choice(FIDELITIES), default="ideal", show_default=True)
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--episodes", type=click.IntRange(1), default=100, show_default=True)
@click.option("--max-steps", type=click.IntRange(10, 500), default=500, show_default=True, help="Steps per episode.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("runs/latest"),
              show_default=True)
@click.option("--checkpoint-every", type=click.IntRange(1), default=10, show_default=True, help="Episodes.")
@click.option("--resume", is_flag=True, help="Continue from the run's last checkpoint.")
@click.option("--randomize", default="", callback=_check_randomize,
              help="Domain randomisation per episode: any of servo,latency,masses,pendulum,pulses,encoder,network "
                   "(comma-separated), or robust for all (docs/adapt.md).")
@click.option("--preset", type=click.Choice(_preset_names()), default=None, help="The servo preset of the twin.")
@click.option("--backend", type=click.Choice(("sim", "rig")), default="sim", show_default=True,
              help="rig: train on a rig over MQTT with the non-blocking trainer (for --seconds).")
@click.option("--rig", "rig_id", default="r01", show_default=True)
@click.option("--broker", default=None, help=f"Broker URL for --backend rig (default {DEFAULT_BROKER}).")
@click.option("--seconds", type=click.FloatRange(1), default=600.0, show_default=True,
              help="Wall-clock training time with --backend rig.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@broker_login_options
def train(algo, fidelity, seed, episodes, max_steps, out_dir, checkpoint_every, resume, randomize, preset, backend,
          rig_id, broker, seconds, quiet, username, password, tls_ca) -> None:
    """Train a learner (DQN, R-DQN, TD3, R-TD3 and their variants) on the twin (or a rig); checkpoints,
    returns and config in --out."""
    torch_or_exit()
    from pendkit.agents.runs import RunSpec, build_run, save_weights
    from pendkit.agents.train import train_sync

    spec = RunSpec(algo, "realistic" if backend == "rig" else fidelity, seed, max_steps, preset, randomize)
    if backend == "rig":
        _train_on_rig(spec, out_dir, rig_id, broker, seconds, login_from(username, password, tls_ca))
        return
    env, agent, inputs = build_run(spec)
    out_dir.mkdir(parents=True, exist_ok=True)
    config = {**spec.to_dict(), "episodes": episodes, "actions_seen": inputs.actions_seen,
              "agent_config": dict(vars(agent.config))}
    (out_dir / "config.json").write_text(json.dumps(config, indent=2))
    returns = train_sync(env, agent, episodes, inputs, seed=seed, progress=not quiet,
                         csv_path=out_dir / "returns.csv", checkpoint_path=out_dir / "checkpoint.pt",
                         checkpoint_every=checkpoint_every, resume=resume)
    save_weights(out_dir / "final.pt", agent, spec, {"episodes": len(returns)})
    click.echo(f"{len(returns)} episodes; last 10 mean return {sum(returns[-10:]) / min(10, len(returns)):.1f}; "
               f"outputs in {out_dir}")


def _train_on_rig(spec, out_dir, rig_id, broker, seconds, login) -> None:
    import csv

    from pendkit.agents.runs import build_run, make_env, save_weights

    env, agent, inputs = build_run(spec, make_env(spec, backend="rig", rig=rig_id, broker=broker,
                                                  rig_options=login.rig_options() or None))
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "config.json").write_text(json.dumps({**spec.to_dict(), "backend": "rig", "rig": rig_id}))
    trainer = AsyncTrainer(agent, [env], [inputs], seed=spec.seed)
    stats = trainer.run(seconds)
    env.close()
    returns = stats.episodes[0]
    with (out_dir / "returns.csv").open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["episode", "return"])
        writer.writerows([k, f"{r:.4f}"] for k, r in enumerate(returns))
    save_weights(out_dir / "final.pt", agent, spec, {"episodes": len(returns), "backend": "rig"})
    click.echo(f"{len(returns)} episodes, {stats.actor_steps[0]} steps, {stats.learner_updates} learner updates, "
               f"{stats.dropped_transitions} transitions dropped; outputs in {out_dir}")


@click.command("eval")
@click.argument("run_dir", type=click.Path(exists=True, file_okay=False, path_type=Path), required=False)
@click.option("--policy", "policy_name", default=None, help="A shipped policy (`pendkit policies list`).")
@click.option("--controller", type=click.Choice(CONTROLLER_NAMES), default=None,
              help="A classical swing-up run from this laptop, designed for --params/--preset (default the kit's rig).")
@click.option("--episodes", type=click.IntRange(1), default=10, show_default=True,
              help="Greedy episodes; the kit's rule judges the first 10 of --start rule.")
@click.option("--backend", type=click.Choice(("sim", "rig")), default="sim", show_default=True,
              help="sim: the run's own twin; rig: a (virtual) rig over MQTT.")
@click.option("--rig", "rig_id", default="r01", show_default=True, help="With --backend rig.")
@click.option("--broker", default=None, help=f"With --backend rig (default {DEFAULT_BROKER}).")
@click.option("--preset", type=click.Choice(_preset_names()), default=None,
              help="On the twin: this servo preset instead of the one trained on; with --controller: the servo "
                   "it is designed for.")
@click.option("--params", "params_path", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=None,
              help="On the twin: a rig saved by RigParams.save (e.g. identified by pendkit adapt); with "
                   "--controller: the rig it is designed for.")
@click.option("--start", type=click.Choice(("rule", "random", "rest")), default="rule", show_default=True,
              help="On the twin: the kit's rule (hanging still and the authors' random starts in turn), only random "
                   "starts, or only hanging still (a rig starts as it is).")
@click.option("--seed", type=int, default=None,
              help="Seed of the first episode's start (default: the rule's reporting starts, never trained on).")
@broker_login_options
def evaluate(run_dir: Path | None, policy_name: str | None, controller: str | None, episodes: int, backend: str,
             rig_id: str, broker: str | None, preset: str | None, params_path: Path | None, start: str, seed: int,
             username, password, tls_ca) -> None:
    """Greedy episodes of a trained run or a shipped policy, on the twin or a rig. Prints the kit's rule and,
    from the first 10 episodes of --start rule, whether the policy is solved by it (`policy_solved=K/10`);
    the last line is `solved=K/N median_upright_s=X` over every episode (an episode is solved when within
    0.3 rad of upright for its last 200 steps). `--controller` does the same for a classical swing-up."""
    torch_or_exit()
    if sum(x is not None for x in (run_dir, policy_name, controller)) != 1:
        raise click.UsageError(f"give one of RUN_DIR, --policy NAME or --controller {'|'.join(CONTROLLER_NAMES)}")
    if controller is not None:
        return evaluate_controller(controller, episodes, backend, rig_id, broker, preset, params_path, start, seed,
                                   login_from(username, password, tls_ca))
    import dataclasses

    from pendkit.agents.policy_artifact import policy_artifact
    from pendkit.agents.policy_rule import REPORT_SEED, RULE_STARTS, RULE_TEXT, PolicyVerdict
    from pendkit.agents.run_folder import restore
    from pendkit.agents.runs import build_run, evaluate_agent, make_env

    try:
        artifact = policy_artifact(run_dir, policy_name)
        state, source = artifact.state, artifact.source
        spec = dataclasses.replace(artifact.spec, preset=preset or artifact.spec.preset, randomize="")
        login = login_from(username, password, tls_ca)
        options = ({"backend": "rig", "rig": rig_id, "broker": broker, "rig_options": login.rig_options() or None}
                   if backend == "rig" else {})
        if params_path is not None:
            spec = dataclasses.replace(spec, preset=None)
            options["params"] = RigParams.load(params_path)
        if backend == "rig" and params_path is None:  # a rig the laptop does not know
            from pendkit.agents.rig_suite import unknown_rig_observer

            options.update(unknown_rig_observer(spec))
        env = make_env(spec, **options)
    except ConfigError as error:
        raise click.ClickException(str(error)) from None
    try:
        _, agent, inputs = build_run(spec, env)
        restore(agent, state, source)
    except ConfigError:
        env.close()
        raise
    seed = REPORT_SEED if seed is None else seed
    starts = [RULE_STARTS[k % len(RULE_STARTS)] for k in range(episodes)] if start == "rule" else start
    try:
        outcome = evaluate_agent(env, agent, inputs, episodes, seed, starts if backend == "sim" else None)
    finally:
        env.close()  # on a classroom broker a link left open would be kicked by (and kick) the team's next one
    click.echo(f"mean return {outcome.mean_return:.1f} over {episodes} episodes")
    click.echo(f"rule: {RULE_TEXT}")
    if start == "rule" and episodes >= len(RULE_STARTS):
        first = dataclasses.replace(outcome, **{name: getattr(outcome, name)[:len(RULE_STARTS)] for name in
                                                ("solved", "upright_s", "returns", "held_fractions")})
        verdict = PolicyVerdict(first, RULE_STARTS if backend == "sim" else (None,) * len(RULE_STARTS), seed)
        click.echo(f"policy: {verdict.summary()} " + " ".join(f"{k}={v}" for k, v in verdict.held_by_start().items()))
    else:
        click.echo(f"policy: not judged (the rule takes --start rule and at least {len(RULE_STARTS)} episodes)")
    click.echo(outcome.summary())


@click.command()
@click.argument("run_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
def plot(run_dir: Path) -> None:
    """Learning curve of a run (returns and a 10-episode mean) to RUN_DIR/learning-curve.png."""
    import csv

    import numpy as np
    from matplotlib.figure import Figure

    if not (run_dir / "returns.csv").is_file():
        raise click.ClickException(f"{run_dir} is not a training run (it has no returns.csv): give the --out folder "
                                   "of `pendkit train`")
    try:
        with (run_dir / "returns.csv").open() as handle:
            returns = [float(row["return"]) for row in csv.DictReader(handle)]
    except (KeyError, ValueError, TypeError) as error:
        raise click.ClickException(f"{run_dir / 'returns.csv'} is not a run's returns file ({error})") from None
    if not returns:
        raise click.ClickException(f"no episodes in {run_dir / 'returns.csv'} yet")
    figure = Figure(figsize=(8, 4), layout="constrained")
    axis = figure.subplots()
    axis.plot(returns, color=PALETTE["limit"], lw=0.8, label="episode return")
    window = min(10, len(returns))
    mean = np.convolve(returns, np.ones(window) / window, mode="valid")
    axis.plot(range(window - 1, len(returns)), mean, color=PALETTE["pendulum"], lw=2, label=f"{window}-episode mean")
    axis.set_xlabel("episode")
    axis.set_ylabel("return")
    axis.legend()
    path = run_dir / "learning-curve.png"
    alt = f"Learning curve of {len(returns)} episodes; the last {window}-episode mean return is {mean[-1]:.1f}."
    figure.savefig(path, dpi=100, metadata={"Description": alt})
    click.echo(f"learning curve: {path}")


@click.group()
def policies() -> None:
    """The policies shipped with the kit (pendkit.agents.pretrained)."""


@policies.command("list")
@click.option("--all", "show_all", is_flag=True,
              help="Also the weights kept below the shipped bar (for studies and the device's blobs).")
def policies_list(show_all: bool) -> None:
    """The shipped policies that hold by the shipped bar: name, learner, twin, training episodes and what each
    measured on its twin (random starts solved, starts hanging still solved, the smallest held share;
    benchmarks/bench_policies.py). `--all` adds the weights kept below the bar, each with what it is kept for."""
    from pendkit.agents.policy_rule import SHIPPED_TEXT
    from pendkit.agents.pretrained import POLICIES, measured_figures, policies_that_hold

    measured, command = measured_figures()
    holding = policies_that_hold()
    below = [name for name in POLICIES if name not in holding]
    for name in POLICIES if show_all else holding:
        _echo_policy(name, measured.get(name, {}), name in holding)
    click.echo(f"the shipped bar: {SHIPPED_TEXT}")
    if below and not show_all:
        click.echo(f"also kept, below the bar (for studies and the device's blobs): {', '.join(below)}; "
                   "`pendkit policies list --all` shows them")
    if command:
        click.echo(f"measured by: {command}")


def _echo_policy(name: str, measured: dict, holds: bool) -> None:
    from pendkit.agents.pretrained import POLICIES, POLICY_DIR, weights_digest

    spec = POLICIES[name]
    twin = spec.run.fidelity + (f" over rigs ({spec.run.randomize})" if spec.run.randomize else "")
    click.echo(f"{name:<24} {spec.run.learner:<14} {twin:<30} {spec.episodes:>5} episodes"
               + ("" if spec.built_by_default else " (built only when named)"))
    figures_of = dict(measured)
    sha = figures_of.pop("weights_sha256", None)
    if figures_of and (POLICY_DIR / f"{name}.pt").exists() and sha != weights_digest(name):
        click.echo(f"{'':<24} (stale: the weights changed since they were measured)")
    for condition, figures in figures_of.items():
        where = "on its twin" if condition == "twin" else f"with two {condition.removeprefix('pushes_')} pushes"
        click.echo(f"{'':<24} measured {where}: random starts {figures['solved']}, hanging {figures['rest']}, "
                   f"held_min {figures['held_min'] if figures['held_min'] is not None else '-'}")
    if "twin" in figures_of:
        verdict = "meets" if holds else "below"
        click.echo(f"{'':<24} {verdict} the shipped bar on its twin" + (f"; {spec.role}" if spec.role else ""))
    else:
        click.echo(f"{'':<24} not measured yet: python benchmarks/bench_policies.py --record")


@policies.command("build")
@click.argument("names", nargs=-1)
def policies_build(names: tuple[str, ...]) -> None:
    """Train the named shipped policies again (all by default) into pendkit/data/policies."""
    torch_or_exit()
    from pendkit.agents.pretrained import build

    try:
        build(list(names) or None)
    except ConfigError as error:
        raise click.ClickException(str(error)) from None


COMMANDS = (train, evaluate, plot, policies)
