"""The broker login every command that talks to a rig takes: `--username`, `--password` (better from the
environment: `PENDKIT_MQTT_USERNAME`, `PENDKIT_MQTT_PASSWORD`, never echoed) and `--tls-ca` (the classroom
CA for an `mqtts://` broker, `pendkit broker-config --tls`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import click


@dataclass(frozen=True)
class BrokerLogin:
    username: str | None = None
    password: str | None = None
    tls_ca: str | None = None

    def rig_options(self) -> dict:
        """What `pendkit.make(backend="rig", rig_options=...)` takes."""
        return {key: value for key, value in
                (("username", self.username), ("password", self.password), ("tls_ca", self.tls_ca)) if value}

    def link_arguments(self) -> dict:
        """What `RigLink(rig, broker, ...)` takes."""
        return {"username": self.username, "password": self.password, "tls_ca": self.tls_ca}


def broker_login_options(function):
    """Add the three options; the command receives them as `login: BrokerLogin`."""

    function = click.option("--tls-ca", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=None,
                            help="The classroom CA (broker/ca.crt) for an mqtts:// broker.")(function)
    function = click.option("--password", envvar="PENDKIT_MQTT_PASSWORD", default=None, show_envvar=True,
                            help="MQTT password (safer in the environment variable: a command line is visible "
                                 "to other users of this machine).")(function)
    function = click.option("--username", envvar="PENDKIT_MQTT_USERNAME", default=None, show_envvar=True,
                            help="MQTT user on a classroom broker (host-r01 for rig r01).")(function)
    return function


def login_from(username: str | None, password: str | None, tls_ca: Path | None) -> BrokerLogin:
    if password is not None and username is None:
        raise click.UsageError("--password needs --username (or PENDKIT_MQTT_USERNAME)")
    return BrokerLogin(username, password, str(tls_ca) if tls_ca is not None else None)
