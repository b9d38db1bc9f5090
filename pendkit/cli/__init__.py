"""The `pendkit` command: thin subcommands over library calls, one module per area.

| module      | commands                                                        |
|-------------|-----------------------------------------------------------------|
| kit.py      | demo, info, bom, cad, wiring, firmware-header                   |
| labs.py     | labs build/check, grade, autograder-run                         |
| learning.py | train, eval, plot, policies list/build                          |
| link.py     | broker, broker-config, virtual-rig                              |
| device.py   | export, deploy                                                  |
| sweep.py    | sweep, sweep report                                             |
"""

from __future__ import annotations

import click

from pendkit.cli import device, kit, labs, learning, link, sweep
from pendkit.errors import PendkitError


class KitGroup(click.Group):
    """Errors the kit raises on purpose (bad settings, no broker, a missing extra) and the operating
    system's (a port taken, a file missing) end a command with one line, never a traceback."""

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except PendkitError as error:
            raise click.ClickException(str(error)) from None
        except OSError as error:
            where = f" ({error.filename})" if getattr(error, "filename", None) else ""
            raise click.ClickException(f"{error.strerror or error}{where}") from None


@click.group(cls=KitGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="pendkit", message="pendkit %(version)s")
def main() -> None:
    """pendkit: the swing-up pendulum teaching kit (twin, rig link, labs, grader)."""


for _module in (kit, labs, learning, link, device, sweep):
    for _command in _module.COMMANDS:
        main.add_command(_command)
