"""`pendkit broker`, `broker-config`, `virtual-rig`: the rig link's commands."""

from __future__ import annotations

import signal
import threading
from pathlib import Path

import click

from pendkit.cli.broker_login import broker_login_options, login_from, password_options
from pendkit.errors import ConfigError
from pendkit.link import DEFAULT_BROKER
from pendkit.link.broker import EmbeddedBroker, read_credentials, write_classroom_config
from pendkit.link.secret_files import folder_closed_to_broker
from pendkit.network import IMPAIRMENTS
from pendkit.rig import SERVO_PRESETS, RigParams

# pendkit modules that load MuJoCo and paho-mqtt are imported inside the functions that use them: importing this
# module does not need them (`pendkit --help` stays quick).


@click.command()
@click.option("--host", default="127.0.0.1", show_default=True, help="Address to listen on (loopback by default).")
@click.option("--port", type=click.IntRange(1, 65535), default=1883, show_default=True)
def broker(host: str, port: int) -> None:
    """Run the embedded MQTT broker (amqtt) until Ctrl-C: enough for one or a few rigs on a laptop."""

    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    with EmbeddedBroker(host, port) as running:
        click.echo(f"broker listening on {running.url}; Ctrl-C to stop")
        stop.wait()


@click.command("broker-config")
@click.option("--rigs", "rig_ids", multiple=True, required=True, help="Rig ids, repeated: --rigs r01 --rigs r02.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("broker"),
              show_default=True)
@click.option("--port", type=click.IntRange(1, 65535), default=1883, show_default=True)
@click.option("--bind", default="0.0.0.0", show_default=True, help="Address Mosquitto listens on.")
@click.option("--tls", "tls_port", type=click.IntRange(1, 65535), default=None, is_flag=False, flag_value=8883,
              help="Also a TLS listener on this port (--tls alone: 8883), with a CA made here (ca.crt for hosts "
                   "and rigs; keep ca.key private).")
@click.option("--address", "addresses", multiple=True,
              help="A name or address the broker is reached by (repeatable: a Pi's name, the room's IP), named in "
                   "the TLS certificate beside this machine's own; a new one reissues it from the same CA.")
@click.option("--new-ca", is_flag=True,
              help="Make a new CA even though ca.key is gone (every rig and host then needs the new ca.crt).")
def broker_config(rig_ids: tuple[str, ...], out_dir: Path, port: int, bind: str, tls_port: int | None,
                  addresses: tuple[str, ...], new_ca: bool) -> None:
    """Write a classroom Mosquitto configuration: per-rig users, an ACL, client ids tied to usernames, no
    anonymous clients. Run it again with more rigs to add them: existing users keep their passwords."""

    try:
        paths = write_classroom_config(list(rig_ids), out_dir, port, bind, tls_port=tls_port,
                                       addresses=list(addresses), new_ca=new_ca)
    except ConfigError as error:
        if tls_port is not None and ("ca.key" in str(error) or "openssl" in str(error)):
            raise click.ClickException(str(error)) from None
        raise click.BadParameter(str(error), param_hint="--rigs") from None
    click.echo(f"wrote {paths['conf']}, {paths['acl']}, {paths['passwords']}")
    if tls_port is not None:
        names = (paths["ca"].parent / "server-names.txt").read_text().split()
        click.echo(f"TLS on port {tls_port}: the certificate names {', '.join(names)}; give hosts and rigs "
                   f"{paths['ca']}; keep {paths['ca_key']} private")
    click.echo(f"passwords for rigs, hosts and the instructor: {paths['credentials']} (keep it private); each "
               f"user's alone in {paths['logins']}/USER.txt: give a team its host-rNN.txt for --password-file")
    click.echo(f"start it with: mosquitto -c {paths['conf']}")

    closed = folder_closed_to_broker(paths["conf"].parent)
    if closed is not None:
        click.echo(f"warning: Mosquitto drops to its own user, who cannot enter {closed}: it would not read the "
                   "password file or the key; write the configuration in a folder others may enter (e.g. "
                   "/srv/pendkit-broker) or let them pass (chmod o+x)")


@click.command("virtual-rig")
@click.option("--rig", "rig_ids", multiple=True, default=("r01",), show_default=True,
              help="Rig id; repeat for several rigs in this process.")
@click.option("--broker", "broker_url", default=DEFAULT_BROKER, show_default=True)
@click.option("--speed", type=click.FloatRange(0.1, 100), default=1.0, show_default=True,
              help="Simulated seconds per real second.")
@click.option("--impairment", type=click.Choice(list(IMPAIRMENTS)), default="none",
              show_default=True, help="Extra latency and loss, as a rig's WiFi would add.")
@click.option("--credentials", "credentials_path", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              default=None, help="The credentials.csv `pendkit broker-config` wrote: each rig logs in as its own "
                                 "user with its own password (no password on the command line).")
@click.option("--tls-ca", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=None,
              help="The classroom CA (broker/ca.crt) for an mqtts:// broker.")
@click.option("--username", default=None, help="MQTT user of a single rig (default: the rig id); its password "
                                                "from PENDKIT_MQTT_PASSWORD or --password-file.")
@password_options
@click.option("--encoder-fault", type=click.Choice(("stuck", "garbage")), default=None,
              help="Simulate a seized or broken encoder (safety demos).")
@click.option("--protocol", type=click.Choice(("v1", "v2")), default="v2", show_default=True,
              help="v1: behave like a rig flashed with the authors' firmware.")
@click.option("--preset", type=click.Choice(sorted(SERVO_PRESETS)), default="hitec-d645mw", show_default=True,
              help="The servo (and its counts range) of the simulated rig.")
@click.option("--params", "params_path", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=None,
              help="The whole rig from a RigParams.save file (servo, masses, pendulum, pulses); replaces --preset.")
def virtual_rig(rig_ids, broker_url, speed, impairment, credentials_path, tls_ca, username, password, password_file,
                encoder_fault, protocol, preset, params_path) -> None:
    """Run virtual rigs: the twin with the firmware's logic, speaking the rig protocol over MQTT."""
    from pendkit.link.driver import RigLinkError, check_rig_id
    from pendkit.link.virtual_rig import VirtualRig, VirtualRigGroup

    for rig in rig_ids:
        try:
            check_rig_id(rig)
        except ConfigError as error:
            raise click.BadParameter(str(error), param_hint="--rig") from None
    try:
        params = RigParams.load(params_path) if params_path is not None else RigParams.preset(preset)
    except ConfigError as error:
        raise click.BadParameter(str(error), param_hint="--params") from None
    if password is not None and password_file is not None:
        raise click.UsageError("the password comes from PENDKIT_MQTT_PASSWORD or --password-file, not both")
    logins = _rig_logins(rig_ids, credentials_path, username, password_file or password)
    rigs = [VirtualRig(rig, broker_url, params=params, impairment=impairment, encoder_fault=encoder_fault,
                       username=logins[rig][0], password=logins[rig][1], protocol=int(protocol[1]),
                       tls_ca=str(tls_ca) if tls_ca else None) for rig in rig_ids]
    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    try:
        group = VirtualRigGroup(rigs, speed).start()
    except RigLinkError as error:
        raise click.ClickException(str(error)) from None
    click.echo(f"virtual rig(s) {', '.join(rig_ids)} on {broker_url} at {speed:g}x; Ctrl-C to stop")
    stop.wait()
    group.stop()


@click.command()
@click.option("--broker", "broker_url", default=DEFAULT_BROKER, show_default=True)
@click.option("--expect", "expected", multiple=True, help="A rig that should be there (repeatable): named if absent.")
@broker_login_options
def rigs(broker_url: str, expected: tuple[str, ...], username, password, tls_ca) -> None:
    """The room's roll call: every rig the broker has heard from, online or not, with what its firmware drives
    (log in as the instructor to see them all; a team's user sees its own rig)."""
    from pendkit.link.roll_call import is_online, rig_line, roll_call

    login = login_from(username, password, tls_ca)
    statuses = roll_call(broker_url, **login.link_arguments())
    for rig, status in statuses.items():
        click.echo(rig_line(rig, status))
    missing = [rig for rig in expected if rig not in statuses]
    hidden = username.startswith("host-") if username else False
    for rig in missing:
        click.echo(f"{rig:<8} not seen by user {username}, which reads only rig {username[5:]}: log in as the "
                   "instructor for the room's roll call" if hidden and rig != username[5:] else
                   f"{rig:<8} never reported to this broker: is it set up with its user and password (and the CA "
                   "for TLS), and is its id on its label?")
    online = sum(is_online(status) for status in statuses.values())
    click.echo(f"{online} of {len(statuses) + len(missing)} rigs online on {broker_url}")
    if missing or online < len(statuses):
        raise SystemExit(1)


COMMANDS = (broker, broker_config, virtual_rig, rigs)


def _rig_logins(rig_ids, credentials_path: Path | None, username: str | None,
                password: str | None) -> dict[str, tuple[str | None, str | None]]:
    """Each rig's (user, password): its own row of credentials.csv, or one --username/--password for one rig."""

    if credentials_path is not None:
        if username or password:
            raise click.UsageError("give either --credentials or --username and a password, not both")
        known = read_credentials(credentials_path)
        missing = [rig for rig in rig_ids if rig not in known]
        if missing:
            raise click.BadParameter(f"{credentials_path} has no user for {', '.join(missing)}: run `pendkit "
                                     f"broker-config` with every rig (--rigs {' --rigs '.join(missing)})",
                                     param_hint="--credentials")
        return {rig: (rig, known[rig]) for rig in rig_ids}
    if password and len(rig_ids) > 1 and username is None:
        raise click.UsageError("each rig has its own password: pass --credentials broker/credentials.csv for "
                               "several rigs")
    return {rig: (username or (rig if password else None), password) for rig in rig_ids}
