"""`pendkit export`: a controller as a blob a rig can run itself (docs/on-device.md)."""

from __future__ import annotations

from pathlib import Path

import click


@click.command()
@click.argument("run_dir", type=click.Path(exists=True, file_okay=False, path_type=Path), required=False)
@click.option("--policy", "policy_name", default=None, help="A shipped policy (`pendkit policies list`).")
@click.option("--out", "out_path", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="The blob to write (.pkcb).")
def export(run_dir: Path | None, policy_name: str | None, out_path: Path) -> None:
    """Write a trained R-DQN (RUN_DIR or --policy NAME) as a controller blob for the device."""
    from pendkit.agents.runs import build_run, load_weights
    from pendkit.device.controller_blob import pack
    from pendkit.device.export import network_blob
    from pendkit.device.policy_runtime import runtime_for

    if (run_dir is None) == (policy_name is None):
        raise click.UsageError("give a RUN_DIR or --policy NAME (one of them)")
    if policy_name is not None:
        from pendkit.agents.pretrained import policy_weights

        spec, state = policy_weights(policy_name)
    else:
        weights = run_dir / "final.pt" if (run_dir / "final.pt").exists() else run_dir / "checkpoint.pt"
        if not weights.exists():
            raise click.ClickException(f"no weights in {run_dir} (final.pt or checkpoint.pt): train one with "
                                       "`pendkit train --algo r-dqn`")
        spec, state = load_weights(weights)
    if spec.learner != "r-dqn":
        raise click.ClickException(f"the device runs R-DQN policies so far; this is a {spec.learner} run "
                                   "(docs/on-device.md says what exists)")
    env, agent, _ = build_run(spec)
    env.close()
    agent.load_policy(state)
    blob = network_blob(agent)
    data = pack(blob)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    out_path.write_bytes(data)
    layers = " x ".join(str(layer.weight.shape[0]) for layer in blob.layers)
    runtime_for(blob).step([0.0] * blob.input_dim)  # it runs
    click.echo(f"wrote {out_path}: {len(data)} bytes, {blob.input_dim} inputs, GRU {blob.gru_size}, layers {layers}, "
               f"{blob.multiply_accumulates} multiply-accumulates per step")


COMMANDS = (export,)
