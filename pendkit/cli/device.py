"""`pendkit export` and `pendkit deploy`: a controller as a blob a rig runs itself, and sending it there
(docs/on-device.md)."""

from __future__ import annotations

import time
from pathlib import Path

import click

from pendkit.cli.broker_login import broker_login_options, login_from
from pendkit.deploy.controllers import CONTROLLER_NAMES, controller_named
from pendkit.deploy.learned_blob import learned_policy_blob
from pendkit.device.controller_blob import BlobError, pack, parse
from pendkit.errors import ConfigError
from pendkit.link import DEFAULT_BROKER
from pendkit.rig import RigParams

# pendkit modules that load MuJoCo, matplotlib, python-control and paho-mqtt are imported inside the functions that
# use them: importing this module does not need them (`pendkit --help` stays quick).

CONTROLLER_CHOICES = CONTROLLER_NAMES
STALE_TELEMETRY_S = 0.5  # an older reading says nothing of the pendulum now


def _rig_params(params_path: Path | None):
    return RigParams() if params_path is None else RigParams.load(params_path)


def _learned_blob(run_dir: Path | None, policy_name: str | None, params_path: Path | None):
    """A trained policy as the device runs it, from RUN_DIR or a shipped policy, and the rig it was made for
    (--params, else the servo preset it was trained on)."""
    from pendkit.agents.policy_artifact import policy_artifact

    try:
        artifact = policy_artifact(run_dir, policy_name)
        made_for = _rig_params(params_path) if params_path is not None else artifact.trained_rig
        return learned_policy_blob(artifact.spec, artifact.state, made_for, source=artifact.source), made_for
    except ConfigError as error:
        raise click.ClickException(str(error)) from None


def _blob(run_dir: Path | None, policy_name: str | None, controller: str | None, params_path: Path | None):
    """(the blob, the rig parameters it was made for)."""
    if sum(x is not None for x in (run_dir, policy_name, controller)) != 1:
        raise click.UsageError(f"give one of RUN_DIR, --policy NAME or --controller {'|'.join(CONTROLLER_NAMES)}")
    if controller is None:
        return _learned_blob(run_dir, policy_name, params_path)
    from pendkit.deploy.swingup_design import design_swing_up

    params = _rig_params(params_path)
    blob = design_swing_up(params, controller)
    note = controller_named(controller).design_note(blob)
    if note:
        click.echo(note)
    return blob, params


def _describe(blob) -> str:
    if blob.kind == "policy":
        network = blob.network
        layers = " x ".join(str(layer.weight.shape[0]) for layer in network.layers)
        observers = f", {blob.observers.candidates} observer(s)" if blob.observers is not None else ""
        return (f"a policy: {network.input_dim} inputs made on the device{observers}, GRU {network.gru_size}, "
                f"layers {layers}")
    plan = f", a plan of {blob.plan_steps} steps from rest" if blob.plan_steps else ""
    return f"swing-up (energy pumping, LQR hand-over{plan})"


_SOURCE_OPTIONS = (
    click.argument("run_dir", type=click.Path(exists=True, file_okay=False, path_type=Path), required=False),
    click.option("--policy", "policy_name", default=None, help="A shipped policy (`pendkit policies list`)."),
    click.option("--controller", type=click.Choice(CONTROLLER_CHOICES), default=None,
                 help="A classical swing-up designed for the rig (pendkit.deploy.controllers)."),
    click.option("--params", "params_path", type=click.Path(exists=True, dir_okay=False, path_type=Path),
                 default=None, help="The rig's parameters (RigParams.save) for --controller, or the rig a policy "
                                   "runs on; default: the kit's rig."),
)


def _with_source(function):
    for option in reversed(_SOURCE_OPTIONS):
        function = option(function)
    return function


@click.command()
@_with_source
@click.option("--out", "out_path", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="The blob to write (.pkcb).")
def export(run_dir, policy_name, controller, params_path, out_path: Path) -> None:
    """Write a controller (RUN_DIR, --policy NAME or --controller NAME) as a blob for the device."""

    blob, _ = _blob(run_dir, policy_name, controller, params_path)
    data = pack(blob)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    out_path.write_bytes(data)
    click.echo(f"wrote {out_path}: {len(data)} bytes, {_describe(blob)}, "
               f"{blob.multiply_accumulates} multiply-accumulates per step")


@click.command()
@_with_source
@click.option("--blob", "blob_path", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=None,
              help="A blob written by `pendkit export`.")
@click.option("--rig", "rig_id", required=True, help="The rig's id (r01, ...).")
@click.option("--broker", default=None, help="The broker's URL; default: this machine's.")
@click.option("--seconds", type=click.FloatRange(0.5, 3600), default=None,
              help="Stop after this long; default: run until Ctrl-C.")
@broker_login_options
def deploy(run_dir, policy_name, controller, params_path, blob_path, rig_id: str, broker: str | None,
           seconds: float | None, username, password, tls_ca) -> None:
    """Upload a controller to a rig, start it, stream its telemetry; Ctrl-C stops it (so does the rig's
    watchdog if this laptop goes away)."""
    from pendkit.deploy.on_rig import (
        RigSession,
        angle_from_upright_rad,
        deploy_verdict,
        run_on_rig,
        servo_range_problem,
        upload_to_rig,
    )
    from pendkit.link.driver import RigLink, check_rig_id

    check_rig_id(rig_id)
    if blob_path is not None:
        if any(x is not None for x in (run_dir, policy_name, controller)):
            raise click.UsageError("give --blob FILE or one of RUN_DIR, --policy, --controller, not both")
        data = blob_path.read_bytes()
        try:
            parse(data)
        except BlobError as error:
            raise click.ClickException(f"{blob_path} is not a controller a rig takes: {error}") from None
        designed_for = None  # a blob file does not say which rig it was designed for
    else:
        blob, designed_for = _blob(run_dir, policy_name, controller, params_path)
        data = pack(blob)
    link = RigLink(rig_id, broker or DEFAULT_BROKER, **login_from(username, password, tls_ca).link_arguments())
    link.connect()
    try:
        session = RigSession(link)
        problem = (servo_range_problem(session.status(), designed_for, f"rig {rig_id}") if designed_for is not None
                   else None)
        if problem is not None:
            raise click.ClickException(f"not uploaded to {rig_id}: {problem}")
        chunks = upload_to_rig(session, data)
        click.echo(f"uploaded {len(data)} bytes to {rig_id} in {chunks} chunks; starting it (Ctrl-C stops)")
        samples: list[tuple[float, float]] = []

        def sample(elapsed_s: float) -> None:
            if link.newest is not None and time.monotonic() - link.newest.receive_time_s < STALE_TELEMETRY_S:
                samples.append((elapsed_s, angle_from_upright_rad(link)))

        outcome = run_on_rig(session, seconds, report=click.echo, on_heartbeat=sample)
        click.echo(f"stopped after {outcome['seconds']} s; telemetry received: {outcome['telemetry']}")
        click.echo(deploy_verdict(samples, designed_for.control_step_ms / 1000 if designed_for is not None
                                  else RigParams().control_step_ms / 1000))
    finally:
        link.close()


COMMANDS = (export, deploy)
