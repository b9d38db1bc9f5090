"""The `pendkit` command: thin subcommands over library calls, one module per area (kit, labs, learning,
link, device, sweep). Every module here with a `COMMANDS` tuple is picked up, so a new command is its
function in its area's module (or a new module) and nothing else; `python -m tests.readme_row` then
rewrites the README's command row.
"""

from __future__ import annotations

import importlib
import pkgutil

import click

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


for _info in sorted(pkgutil.iter_modules(__path__), key=lambda info: info.name):
    if _info.name.startswith("_"):
        continue
    for _command in getattr(importlib.import_module(f"{__name__}.{_info.name}"), "COMMANDS", ()):
        main.add_command(_command)
