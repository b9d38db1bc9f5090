"""`pendkit sweep SPEC --out DIR` and `pendkit sweep report DIR`: learning sweeps on Ray Tune (docs/sweeps.md)."""

from __future__ import annotations

import json
import shlex
import sys
from pathlib import Path

import click

from pendkit.safe_write import check_no_links, write_text
from pendkit.sweep.ray_runner import run_sweep
from pendkit.sweep.spec import load_spec

# pendkit modules that load torch and MuJoCo are imported inside the functions that use them: importing this module
# does not need them (`pendkit --help` stays quick).


class SweepGroup(click.Group):
    """`pendkit sweep SPEC ...` runs a spec; `pendkit sweep report DIR` reports (a subcommand by name)."""

    def resolve_command(self, ctx, args):
        if args and args[0] not in self.commands and not args[0].startswith("-"):
            args = ["run", *args]
        return super().resolve_command(ctx, args)


@click.group(cls=SweepGroup)
def sweep() -> None:
    """Learning sweeps (learners x fidelities, delays or rig files x seeds) as Ray Tune trials.

    \b
    pendkit sweep SPEC.yaml --out DIR [--address auto|ray://HOST:10001] [--resume] [--seeds N ...]
    pendkit sweep report DIR [MORE_DIRS ...] [--delay-sweep-json FILE]
    """


@sweep.command("run")
@click.argument("spec_path", metavar="SPEC", type=click.Path(path_type=Path))
@click.option("--out", "out", type=click.Path(path_type=Path), required=True, help="the sweep's folder")
@click.option("--address", default=None,
              help="an existing Ray cluster: auto (this machine's) or ray://HOST:10001; default: a local Ray")
@click.option("--resume", is_flag=True, help="continue the sweep in --out: finished trials are not run again")
@click.option("--cpus-per-trial", type=float, default=1.0, show_default=True)
@click.option("--cpus", type=click.IntRange(min=1), default=None,
              help="CPUs the local Ray may use (default: all of this machine's); not with --address")
@click.option("--seeds", "seeds", type=click.IntRange(min=0), multiple=True,
              help="run these seeds instead of the spec's (repeat: --seeds 4 --seeds 5)")
def run(spec_path: Path, out: Path, address: str | None, resume: bool, cpus_per_trial: float,
        cpus: int | None, seeds: tuple[int, ...]) -> None:
    """Run SPEC's trials through Ray Tune into --out, then print the summary."""
    from pendkit.sweep.report import report

    spec = load_spec(spec_path, list(seeds))
    click.echo(f"sweep {spec.name}: {len(spec.trials)} trials ({', '.join(spec.learners)})")
    if cpus is not None and address is not None:
        raise click.UsageError("--cpus sizes a local Ray; a cluster at --address has its own")
    facts = run_sweep(spec, out, address, resume, cpus_per_trial, say=click.echo, num_cpus=cpus)
    write_text(Path(out) / "command.txt", shlex.join(["pendkit", "sweep", *sys.argv[2:]]) + "\n")
    click.echo(f"ran {facts['ran']} trials, skipped {facts['skipped']} finished ones; Ray's start-up "
               f"{facts['ray_start_s']:.1f} s")
    report(out, say=click.echo)


@sweep.command("report")
@click.argument("out", metavar="DIR", type=click.Path(path_type=Path))
@click.argument("more", metavar="[MORE_DIRS]...", nargs=-1, type=click.Path(path_type=Path))
@click.option("--delay-sweep-json", type=click.Path(path_type=Path), default=None,
              help="also write a delay sweep in lab 08's format (pendkit/data/delay_sweep.json)")
@click.option("--no-figure", is_flag=True)
def report_command(out: Path, more: tuple[Path, ...], delay_sweep_json: Path | None, no_figure: bool) -> None:
    """Gather DIR's trials (and MORE_DIRS', a class's runs side by side) into DIR's table.csv/table.json,
    print the summary lines, draw summary.png."""
    from pendkit.sweep.report import delay_sweep_record, report

    if delay_sweep_json is not None:
        check_no_links(delay_sweep_json)
    rows = report(out, say=click.echo, figure=not no_figure, more=list(more))
    if delay_sweep_json is not None:
        command_file = Path(out) / "command.txt"
        command = command_file.read_text().strip() if command_file.exists() else f"pendkit sweep ... --out {out}"
        command = f"{command}; pendkit sweep report {out} --delay-sweep-json {delay_sweep_json}"
        for where in (str(Path(out).resolve()), str(out)):  # the folder's name on this machine says nothing
            command = command.replace(where, "DIR")
        record = delay_sweep_record(rows, command)
        write_text(delay_sweep_json, json.dumps(record, indent=1) + "\n")
        click.echo(f"wrote {delay_sweep_json}")


COMMANDS = (sweep,)
