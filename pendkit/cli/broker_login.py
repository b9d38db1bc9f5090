"""The broker login every command that talks to a rig takes: `--username` (or `PENDKIT_MQTT_USERNAME`), the
password from the environment (`PENDKIT_MQTT_PASSWORD`) or a file (`--password-file`), never the command line
(every user of a machine can read a command line with `ps`), and `--tls-ca` (the classroom CA for an
`mqtts://` broker, `pendkit broker-config --tls`)."""

from __future__ import annotations

import functools
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


def refused_on_command_line(what: str, variable: str, file_option: str):
    """A click callback taking a secret from `variable` only: given on the command line (where every user of the
    machine reads it with `ps`), it is refused, naming the variable and `file_option`."""
    def callback(ctx: click.Context, param: click.Parameter, value: str | None) -> str | None:
        if value is not None and ctx.get_parameter_source(param.name) == click.core.ParameterSource.COMMANDLINE:
            raise click.BadParameter(f"a {what} on the command line is visible to every user of this machine "
                                     f"(`ps`): set {variable} in the environment, or give {file_option} FILE",
                                     param_hint=f"--{what}")
        return value

    return callback


_password_from_environment = refused_on_command_line("password", "PENDKIT_MQTT_PASSWORD", "--password-file")


def _password_file(ctx: click.Context, param: click.Parameter, value: Path | None) -> str | None:
    """The first line of the file (its own line ending dropped)."""
    if value is None:
        return None
    try:
        lines = value.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as error:
        raise click.BadParameter(f"cannot read {value}: {error}", param_hint="--password-file") from None
    if not lines or not lines[0]:
        raise click.BadParameter(f"{value} is empty: its first line is the password", param_hint="--password-file")
    if lines[0].startswith("user,password") or ":$7$" in lines[0]:
        kind = "credentials table" if "," in lines[0] else "hashed password file"
        raise click.BadParameter(f"{value} is broker-config's {kind}, not one password: use broker/logins/USER.txt",
                                 param_hint="--password-file")
    return lines[0]


def password_options(function):
    """`--password` taken from PENDKIT_MQTT_PASSWORD only (refused on the command line) and `--password-file`;
    the command receives `password` and `password_file` (the file's password)."""
    function = click.option("--password-file", type=click.Path(exists=True, dir_okay=False, path_type=Path),
                            default=None, callback=_password_file,
                            help="A file whose first line is the MQTT password (instead of PENDKIT_MQTT_PASSWORD)."
                            )(function)
    return click.option("--password", envvar="PENDKIT_MQTT_PASSWORD", default=None, show_envvar=True, hidden=True,
                        callback=_password_from_environment, expose_value=True)(function)


def broker_login_options(function):
    """Add the login options; the command receives `username`, `password` (from the environment or
    --password-file) and `tls_ca`."""

    @functools.wraps(function)
    def with_one_password(*args, password_file: str | None = None, password: str | None = None, **kwargs):
        if password_file is not None and password is not None:
            raise click.UsageError("the password comes from PENDKIT_MQTT_PASSWORD or --password-file, not both")
        return function(*args, password=password_file if password_file is not None else password, **kwargs)

    command = click.option("--tls-ca", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=None,
                           help="The classroom CA (broker/ca.crt) for an mqtts:// broker.")(with_one_password)
    command = password_options(command)
    return click.option("--username", envvar="PENDKIT_MQTT_USERNAME", default=None, show_envvar=True,
                        help="MQTT user on a classroom broker (host-r01 for rig r01); its password from "
                             "PENDKIT_MQTT_PASSWORD or --password-file.")(command)


def login_from(username: str | None, password: str | None, tls_ca: Path | None) -> BrokerLogin:
    if password is not None and username is None:
        raise click.UsageError("a password (PENDKIT_MQTT_PASSWORD or --password-file) needs --username "
                               "(or PENDKIT_MQTT_USERNAME)")
    return BrokerLogin(username, password, str(tls_ca) if tls_ca is not None else None)
