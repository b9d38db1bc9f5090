"""The README's command row, written from the CLI itself so a new command touches only its own module.

`python -m tests.readme_row` rewrites the row in README.md; `tests/test_docs.py` checks it is current.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click

ROW_START = "| the command | `pendkit/cli/` | "


def command_names(group: click.Group) -> list[str]:
    """Every command as the README shows it: a group with its subcommands (`labs build/check`)."""
    names = []
    for name in sorted(group.commands):
        command = group.commands[name]
        if isinstance(command, click.Group) and command.commands:
            names.append(f"{name} {'/'.join(sorted(command.commands))}")
        else:
            names.append(name)
    return names


def command_row(group: click.Group) -> str:
    first, *rest = command_names(group)
    listed = ", ".join([f"`pendkit {first}`", *(f"`{name}`" for name in rest)])
    return f"{ROW_START}{listed} (`pendkit COMMAND --help` on each) |"


def rewrite(readme: Path, group: click.Group) -> bool:
    """Put the current row in `readme`; True when it changed."""
    lines = readme.read_text().splitlines(keepends=True)
    at = next((i for i, line in enumerate(lines) if line.startswith(ROW_START)), None)
    if at is None:
        raise SystemExit(f"{readme}: no line starts with {ROW_START!r}")
    row = command_row(group) + "\n"
    if lines[at] == row:
        return False
    lines[at] = row
    readme.write_text("".join(lines))
    return True


if __name__ == "__main__":
    from pendkit.cli import main

    target = Path(sys.argv[1] if len(sys.argv) > 1 else "README.md")
    print(f"{target}: {'rewritten' if rewrite(target, main) else 'already current'}")
