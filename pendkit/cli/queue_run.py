"""`pendkit queue run`: a runner serving rigs from the queue (`pendkit.queue.runner`); `pendkit.cli.queue`'s group
adds it. Real rigs over a broker (`--rig`), virtual ones on an embedded broker in this process (`--virtual`)."""

from __future__ import annotations

import signal
import socket
import threading

import click

from pendkit.cli.broker_login import broker_login_options, login_from
from pendkit.errors import ConfigError, MissingExtraError
from pendkit.link import DEFAULT_BROKER

# pendkit modules that load torch, MuJoCo, SQLAlchemy, matplotlib, python-control and paho-mqtt are imported inside
# the functions that use them: importing this module does not need them (`pendkit --help` stays quick).


@click.command("run")
@click.option("--db", default="sqlite:///queue.db", envvar="PENDKIT_QUEUE_DB", show_default=True, show_envvar=True,
              help="The queue's database: an SQLite file or a PostgreSQL URL (postgresql+psycopg://...).")
@click.option("--rig", "rig_ids", multiple=True, help="A rig to serve over --broker (repeatable).")
@click.option("--broker", default=DEFAULT_BROKER, show_default=True, help="The rigs' broker (with --rig).")
@click.option("--virtual", "virtual_ids", multiple=True,
              help="A virtual rig to serve, run here on an embedded broker (repeatable): the twin as a rig.")
@click.option("--speed", type=click.FloatRange(0.1, 100), default=1.0, show_default=True,
              help="The virtual rigs' time per wall second (a rig's own status says its speed).")
@click.option("--name", default=None, help="This runner's name in the queue (default: this machine's name); "
                                           "started again under it, it gives back the jobs it left running.")
@click.option("--twin/--no-twin", default=True, show_default=True,
              help="Also judge each blob on the twin with two hand pushes an episode (the leaderboard's column).")
@click.option("--once", is_flag=True, help="Stop when no job is left that these rigs could run.")
@broker_login_options
def run(db, rig_ids, broker, virtual_ids, speed, name, twin, once, username, password, tls_ca) -> None:
    """Serve rigs from the queue: reset each between episodes, judge by the kit's rule, store the results.

    On a classroom broker a runner serving several rigs logs in as the instructor (a team's host user reaches
    its own rig only)."""
    from pendkit.link.driver import RigLink, RigLinkError, check_rig_id

    if not rig_ids and not virtual_ids:
        raise click.UsageError("give the rigs to serve: --rig r01 (over --broker) or --virtual r01 (the twin)")
    duplicated = sorted({rig for rig in rig_ids + virtual_ids if (rig_ids + virtual_ids).count(rig) > 1})
    if duplicated:
        raise click.UsageError(f"rig {duplicated[0]} given twice")
    for rig in rig_ids + virtual_ids:
        try:
            check_rig_id(rig)
        except ConfigError as error:
            raise click.BadParameter(str(error), param_hint="--rig/--virtual") from None
    try:
        from pendkit.queue.runner import QueueRunner
        from pendkit.queue.store import QueueStore
    except ImportError as error:
        raise MissingExtraError(f"the queue needs SQLAlchemy ({error.name}): pip install 'pendkit[queue]'") from None
    store = QueueStore(db)
    virtual = None
    try:
        links = [RigLink(rig, broker, **login_from(username, password, tls_ca).link_arguments()) for rig in rig_ids]
        if virtual_ids:
            from pendkit.queue.virtual import VirtualRigs

            virtual = VirtualRigs(list(virtual_ids), speed).start()
            links += virtual.links()
            click.echo(f"virtual rig(s) {', '.join(virtual_ids)} at {speed:g}x on {virtual.url}")
        from pendkit.adapt.queued import record_excitation

        runner = QueueRunner(store, links, name or socket.gethostname(), speed=speed,
                             say=lambda line: click.echo(line), twin_pushes=twin, excitation=record_excitation)
        restore = _stop_on_signals(runner)
        try:
            runner.run(once=once)
        finally:
            restore()
    except RigLinkError as error:
        raise click.ClickException(str(error)) from None
    finally:
        if virtual is not None:
            virtual.stop()
        store.close()
    click.echo(f"runner {runner.name} stopped")


def _stop_on_signals(runner):
    """Ctrl-C or SIGTERM: the running jobs go back to waiting, their rigs stopped and holding. Returns what puts
    the handlers back."""
    if threading.current_thread() is not threading.main_thread():
        return lambda: None  # signals are the main thread's
    before = {number: signal.getsignal(number) for number in (signal.SIGINT, signal.SIGTERM)}
    for number in before:
        signal.signal(number, lambda *_: runner.stopping.set())
    return lambda: [signal.signal(number, handler) for number, handler in before.items()]


if __name__ == "__main__":  # `python -m pendkit.cli.queue_run ...`: the runner alone (the tests kill it)
    run()
