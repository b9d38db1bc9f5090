"""`pendkit queue`: a class's rigs shared by a queue. The instructor serves it (`serve`), loads the teams
(`teams`) and looks after the rigs (`rigs`); runners take its jobs (`run`); teams submit and follow their jobs
(`submit`, `status`, `result`, `cancel`) from a laptop, as `QueueClient` does from a notebook."""

from __future__ import annotations

import ipaddress
import json
import signal
import threading
from pathlib import Path

import click

from pendkit.cli.broker_login import refused_on_command_line
from pendkit.deploy.controllers import CONTROLLER_NAMES
from pendkit.errors import MissingExtraError
from pendkit.link.broker import read_credentials
from pendkit.queue.client import QueueClient
from pendkit.rig import SERVO_PRESETS

# pendkit modules that load SQLAlchemy are imported inside the functions that use them: importing this module does not
# need them (`pendkit --help` stays quick).

DB_HELP = "The queue's database: an SQLite file, or an SQLAlchemy URL (postgresql+psycopg://...)."


@click.group()
def queue() -> None:
    """Share a class's rigs: a queue of jobs judged on the rigs, a class page, each team's results."""


def _db_option(function):
    return click.option("--db", default="queue.db", envvar="PENDKIT_QUEUE_DB", show_default=True, show_envvar=True,
                        help=DB_HELP)(function)


def _open_store(db: str):
    try:
        from pendkit.queue.store import QueueStore
    except ImportError:
        raise MissingExtraError('the queue keeps its state through SQLAlchemy: pip install -e ".[queue]"') from None
    return QueueStore(db)


@queue.command()
@_db_option
@click.option("--bind", default="127.0.0.1", show_default=True,
              help="Address to listen on: loopback by default; the room's address (or 0.0.0.0) for a class.")
@click.option("--port", type=click.IntRange(1, 65535), default=8790, show_default=True)
@click.option("--max-upload-kb", type=click.IntRange(1, 65536), default=1024, show_default=True,
              help="The largest job request accepted.")
@click.option("--tls-cert", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=None,
              help="Serve https with this certificate (broker-config --tls's broker/server.crt).")
@click.option("--tls-key", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=None,
              help="Its key (broker/server.key).")
def serve(db: str, bind: str, port: int, max_upload_kb: int, tls_cert: Path | None, tls_key: Path | None) -> None:
    """Serve the queue's API and class page until Ctrl-C (one log line per request, never a token)."""
    from pendkit.queue.server import QueueServer

    if (tls_cert is None) != (tls_key is None):
        raise click.UsageError("give --tls-cert and --tls-key together")
    store = _open_store(db)
    tls = (str(tls_cert), str(tls_key)) if tls_cert is not None else None
    server = QueueServer(store, bind, port, max_upload_kb * 1024, log=lambda line: click.echo(line, err=True),
                         tls=tls)
    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    server.start()
    click.echo(f"queue on {server.url} (class page /, API /api); database {_shown(store)}; Ctrl-C to stop")
    if tls is None and not _loopback(bind):
        click.echo("warning: plain http on a network: tokens (the teams' broker passwords) cross it readable; "
                   "--tls-cert broker/server.crt --tls-key broker/server.key serves https", err=True)
    try:
        stop.wait()
    finally:
        server.close()
        store.close()


def _shown(store) -> str:
    """The database's URL without its password."""
    import sqlalchemy as sa

    return sa.engine.make_url(store.url).render_as_string(hide_password=True)


def _loopback(bind: str) -> bool:
    try:
        return ipaddress.ip_address(bind).is_loopback
    except ValueError:
        return bind == "localhost"


# --- a team's commands ---
_refuse_token_on_command_line = refused_on_command_line("token", "PENDKIT_QUEUE_TOKEN", "--token-file")


def _client_options(function):
    function = click.option("--tls-ca", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=None,
                            help="The classroom CA (broker/ca.crt) for an https queue.")(function)
    function = click.option("--token-file", type=click.Path(exists=True, dir_okay=False, path_type=Path),
                            default=None, help="Your team's login file (host-rNN.txt): its first line is the token "
                                               "(instead of PENDKIT_QUEUE_TOKEN).")(function)
    function = click.option("--token", envvar="PENDKIT_QUEUE_TOKEN", default=None, hidden=True,
                            callback=_refuse_token_on_command_line)(function)
    return click.option("--server", envvar="PENDKIT_QUEUE_SERVER", default="http://127.0.0.1:8790",
                        show_default=True, show_envvar=True, help="The queue's address.")(function)


def _client(server: str, token: str | None, token_file: Path | None, tls_ca: Path | None):
    if token is not None and token_file is not None:
        raise click.UsageError("the token comes from PENDKIT_QUEUE_TOKEN or --token-file, not both")
    return QueueClient(server, token=token, token_file=token_file, tls_ca=tls_ca)


@queue.command()
@click.option("--controller", type=click.Choice(CONTROLLER_NAMES), default=None,
              help="The kit's swing-up controller, designed for the rig (--preset or --params).")
@click.option("--preset", type=click.Choice(sorted(SERVO_PRESETS)), default=None, help="With --controller: the servo.")
@click.option("--params", "params_path", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=None,
              help="With --controller: the rig's parameters (RigParams.save, e.g. from pendkit adapt).")
@click.option("--episodes", type=click.IntRange(min=1), default=None,
              help="With --controller: episodes to run (the kit's rule: 10).")
@click.option("--blob", "blob_path", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=None,
              help="A device blob (.pkcb, pendkit export) to judge on a rig.")
@click.option("--policy", "policy_name", default=None, help="A shipped policy (pendkit policies list).")
@click.option("--excitation", is_flag=True, help="Record pendkit adapt's excitation (about 40 s) on a rig.")
@click.option("--priority", type=click.IntRange(-10, 10), default=0, help="The instructor's only: higher runs first.")
@click.option("--time-limit-s", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Stop the job after this many of the rig's seconds (default: its episodes and resets at the "
                   "longest).")
@_client_options
def submit(controller, preset, params_path, episodes, blob_path, policy_name, excitation, priority, time_limit_s,
           server, token, token_file, tls_ca) -> None:
    """Queue a job for your team: a controller, a blob, a shipped policy or an excitation."""
    chosen = [name for name, given in (("--controller", controller), ("--blob", blob_path),
                                       ("--policy", policy_name), ("--excitation", excitation)) if given]
    if len(chosen) != 1:
        raise click.UsageError("give one of --controller, --blob, --policy or --excitation"
                               + (f" (got {', '.join(chosen)})" if chosen else ""))
    if controller is None and (preset or params_path or episodes):
        raise click.UsageError("--preset, --params and --episodes go with --controller")
    if preset is not None and params_path is not None:
        raise click.UsageError("give --preset or --params, not both")
    client = _client(server, token, token_file, tls_ca)
    common = {"priority": priority, "time_limit_s": time_limit_s}
    if controller is not None:
        params = None
        if params_path is not None:
            try:
                params = json.loads(params_path.read_text())
            except (ValueError, UnicodeDecodeError) as error:
                raise click.BadParameter(f"{params_path} is not RigParams.save's JSON: {error}",
                                         param_hint="--params") from None
        job_id = client.submit_controller(controller, preset, params, episodes, **common)
    elif blob_path is not None:
        job_id = client.submit_blob(blob_path, **common)
    elif policy_name is not None:
        job_id = client.submit_policy(policy_name, **common)
    else:
        job_id = client.submit_excitation(**common)
    click.echo(f"job {job_id} queued on {client.server}")
    click.echo(f"follow it: pendkit queue status {job_id} --wait (or open {client.server}/jobs/{job_id}); "
               f"its result: pendkit queue result {job_id} --out results")


def _verdict(job: dict) -> str:
    found = job.get("figures")
    if not found:
        return job.get("reason") or "-"
    upright = found.get("time_to_upright_s")
    return f"{found['verdict']} upright_s={upright:.2f}" if upright is not None else found["verdict"]


def _say_job(job: dict) -> None:
    rig = f" on {job['rig']}" if job.get("rig") else ""
    click.echo(f"job {job['id']} ({job['kind']}): {job['state']}{rig}; {_verdict(job)}")


@queue.command()
@click.argument("job_id", metavar="[JOB]", type=click.IntRange(min=1), required=False)
@click.option("--wait", is_flag=True, help="With JOB: follow it until it has finished.")
@_client_options
def status(job_id, wait, server, token, token_file, tls_ca) -> None:
    """Your team's jobs, or one job (--wait: until it finishes)."""
    client = _client(server, token, token_file, tls_ca)
    if job_id is None:
        if wait:
            raise click.UsageError("--wait follows one job: pendkit queue status JOB --wait")
        listed = client.jobs()
        for job in listed:
            _say_job(job)
        click.echo(f"{len(listed)} jobs of your team on {client.server}")
        return
    job = client.wait(job_id, on_change=_say_job) if wait else client.job(job_id)
    if not wait:
        _say_job(job)


@queue.command()
@click.argument("job_id", metavar="JOB", type=click.IntRange(min=1))
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), required=True,
              help="Folder for the job's summary (JSON), telemetry (CSV) and plot (PNG).")
@_client_options
def result(job_id, out_dir, server, token, token_file, tls_ca) -> None:
    """Download a finished job's result."""
    client = _client(server, token, token_file, tls_ca)
    written = client.download(job_id, out_dir)
    _say_job(json.loads(written["job"].read_text()))
    click.echo("wrote " + ", ".join(str(path) for path in written.values()))


@queue.command()
@click.argument("job_id", metavar="JOB", type=click.IntRange(min=1))
@_client_options
def cancel(job_id, server, token, token_file, tls_ca) -> None:
    """Cancel a waiting or running job of your team's (a running one stops at the runner's next check)."""
    _client(server, token, token_file, tls_ca).cancel(job_id)
    click.echo(f"job {job_id} cancelled")


# --- the instructor's ---
@queue.command()
@click.option("--credentials", "credentials_path", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              default=Path("broker/credentials.csv"), show_default=True,
              help="The credentials.csv pendkit broker-config wrote: each host-rNN user is a team.")
@click.option("--quota-minutes", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Each team's rig-minutes per day (default: no limit).")
@_db_option
def teams(credentials_path: Path, quota_minutes: float | None, db: str) -> None:
    """Load the teams into the queue: each host-rNN user of broker-config is a team whose token is its password,
    the instructor user the instructor. Prints the teams, never a token."""

    logins = read_credentials(credentials_path)
    team_logins = {user: password for user, password in logins.items() if user.startswith("host-")}
    if not team_logins:
        raise click.BadParameter(f"{credentials_path} has no host-rNN user: run pendkit broker-config --rigs r01 "
                                 "... first", param_hint="--credentials")
    store = _open_store(db)
    quota_rig_s = quota_minutes * 60 if quota_minutes is not None else None
    for user, password in sorted(team_logins.items()):
        store.add_team(user, password, quota_rig_s)
        click.echo(f"team {user}")
    if "instructor" in logins:
        store.add_team("instructor", logins["instructor"], None, instructor=True)
        click.echo("team instructor (the instructor: may set a priority and cancel any job)")
    where = _shown(store)
    store.close()
    quota = f"{quota_minutes:g} rig-minutes per team per day" if quota_minutes is not None else "no quota"
    click.echo(f"{len(team_logins)} teams in {where}; {quota}; each team's token is its login file's line "
               "(broker/logins/host-rNN.txt)")


@queue.command()
@click.option("--put-back", "put_back", default=None, metavar="RIG",
              help="Put a rig taken out of service back in (once you have seen to it).")
@_db_option
def rigs(put_back: str | None, db: str) -> None:
    """The queue's rigs: free, busy or out of service with the reason."""
    store = _open_store(db)
    try:
        known = {row["rig"]: row for row in store.rigs()}
        if put_back is not None:
            if put_back not in known:
                raise click.BadParameter(f"no rig {put_back!r} in the queue (it has: {', '.join(known) or 'none'})",
                                         param_hint="--put-back")
            if not store.put_back(put_back):
                raise click.BadParameter(f"rig {put_back} is {known[put_back]['state']}, not out of service",
                                         param_hint="--put-back")
            click.echo(f"rig {put_back} is back in service")
            known = {row["rig"]: row for row in store.rigs()}
        for row in known.values():
            servo = f"{row['servo_min']}-{row['servo_max']}" if row["servo_min"] is not None else "any"
            job = f"job {row['job_id']}" if row["job_id"] is not None else "no job"
            reason = f": {row['reason']}" if row["reason"] else ""
            click.echo(f"{row['rig']:<8} {row['state']:<5} {job:<10} servo {servo:<9} runner {row['runner']}{reason}")
        click.echo(f"{len(known)} rigs in {_shown(store)}")
    finally:
        store.close()


try:  # the runner's command lands in its own module
    from pendkit.cli.queue_run import run
except ImportError:
    pass
else:
    queue.add_command(run)

COMMANDS = (queue,)
