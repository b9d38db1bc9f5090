"""`pendkit labs build/check`, `pendkit grade` and `pendkit autograder-run` (Gradescope's per-submission entry)."""

from __future__ import annotations

import math
from pathlib import Path

import click


@click.group()
def labs() -> None:
    """Build the student labs from solutions/ and check they are current."""


@labs.command("build")
@click.option("--solutions", "solutions_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("solutions"), show_default=True, help="Solution notebooks (the single source).")
@click.option("--out", "labs_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("labs"),
              show_default=True, help="Where to write the student copies.")
def labs_build(solutions_dir: Path, labs_dir: Path) -> None:
    """Write labs/NN_name.ipynb from solutions/ (stubs for solutions, no instructor cells)."""
    from pendkit.errors import ConfigError
    from pendkit.labs.build import build

    try:
        written = build(solutions_dir, labs_dir)
    except ConfigError as error:
        raise click.ClickException(str(error)) from None
    for path in written:
        click.echo(f"wrote {path}")


@labs.command("check")
@click.option("--solutions", "solutions_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("solutions"), show_default=True)
@click.option("--labs", "labs_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("labs"),
              show_default=True)
def labs_check(solutions_dir: Path, labs_dir: Path) -> None:
    """Fail if labs/ differs from what `pendkit labs build` would write."""
    from pendkit.errors import ConfigError
    from pendkit.labs.build import stale

    try:
        problems = stale(solutions_dir, labs_dir)
    except ConfigError as error:
        raise click.ClickException(str(error)) from None
    if problems:
        for problem in problems:
            click.echo(problem, err=True)
        raise click.ClickException("labs/ is stale: run `pendkit labs build`")
    click.echo("labs/ is up to date")


def _seconds(ctx, param, value: float | None) -> float | None:
    """A time limit: positive and finite (fractions allowed; a cell's limit is rounded up to whole seconds)."""
    if value is not None and not (math.isfinite(value) and value > 0):
        raise click.BadParameter(f"a time limit must be a positive number of seconds, got {value}")
    return value


def _lab(ctx, param, value: str | None) -> str | None:
    from pendkit.grading.core import known_labs

    if value is not None and value not in known_labs():
        raise click.BadParameter(f"the kit has no lab {value!r}: its labs are {', '.join(known_labs())}")
    return value


@click.command()
@click.argument("submissions", type=click.Path(exists=True, file_okay=False, path_type=Path), required=False)
@click.option("--lab", default=None, callback=_lab, help="Grade only this lab (NN); default: from each notebook.")
@click.option("--gradescope-autograder", "autograder_zip", type=click.Path(dir_okay=False, path_type=Path),
              default=None, help="Instead of grading: write Gradescope's autograder zip for --lab NN.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("grades"),
              show_default=True, help="Where results.json files and grades.csv go.")
@click.option("--hidden", "hidden_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("solutions/tests"), show_default=True, help="Hidden tests (labNN_*.py).")
@click.option("--cell-timeout", type=float, default=120.0, show_default=True, callback=_seconds,
              help="Seconds per cell.")
@click.option("--notebook-timeout", type=float, default=600.0, show_default=True, callback=_seconds,
              help="Seconds per notebook.")
@click.option("--check-timeout", type=float, default=None, callback=_seconds,
              help="Cap on each test's own time limit, in seconds (default: the test's, usually 10).")
@click.option("--jobs", type=click.IntRange(1, 64), default=1, show_default=True,
              help="Notebooks graded at once (each runs its own kernel: about one core each).")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@click.pass_context
def grade(ctx: click.Context, submissions: Path | None, lab: str | None, autograder_zip: Path | None, out_dir: Path,
          hidden_dir: Path, cell_timeout: float, notebook_timeout: float, check_timeout: float | None, jobs: int,
          quiet: bool) -> None:
    """Run and grade every submitted notebook; write Gradescope results.json files and a CSV."""
    from pendkit.grading.report import grade_folder
    from pendkit.grading.sandbox import isolation_problem

    hidden = hidden_dir if hidden_dir.is_dir() else None
    if hidden is None and ctx.get_parameter_source("hidden_dir") != click.core.ParameterSource.DEFAULT:
        raise click.BadParameter(f"{hidden_dir} is not a folder of hidden tests", param_hint="--hidden")
    public_only = (f"no hidden tests at {hidden_dir}: graded with the public tests only, so every score below is "
                   "out of the public points; pass --hidden with the kit's solutions/tests to grade out of all of them")
    if hidden is None:
        click.echo(public_only, err=True)
    if autograder_zip is not None:
        from pendkit.grading.gradescope import build_autograder

        if lab is None:
            raise click.BadParameter("say which lab the autograder is for", param_hint="--lab")
        click.echo(f"wrote {build_autograder(autograder_zip, lab, hidden)}: upload it as the assignment's "
                   "autograder (docs/labs-and-grading.md)")
        return
    if submissions is None:
        raise click.BadParameter("give the folder of submitted notebooks", param_hint="SUBMISSIONS")
    problem = isolation_problem()
    if problem is not None:
        click.echo(f"WARNING: isolation is off ({problem}): student code runs as you, with your files and "
                   "network. Grade on Linux with bubblewrap for a class.", err=True)
    grades = grade_folder(submissions, out_dir, lab, hidden, cell_timeout, notebook_timeout, check_timeout,
                          progress=not quiet, jobs=jobs)
    if not grades:
        raise click.ClickException(f"no notebooks found in {submissions}")
    for result in grades:
        click.echo(f"{result.student:<24} lab {result.lab}  {result.score:g}/{result.max_score:g}"
                   + (f"  ({len(result.notes)} notes)" if result.notes else ""))
    click.echo(f"reports: {out_dir / 'grades.csv'} and {out_dir}/<student>/results.json")
    if hidden is None:  # said again at the end, where an instructor reads the scores
        click.echo(f"NOTE: {public_only}", err=True)


@click.command("autograder-run")
@click.option("--root", type=click.Path(exists=True, file_okay=False, path_type=Path), default=Path("/autograder"),
              show_default=True, help="Gradescope's autograder folder.")
@click.option("--lab", required=True, callback=_lab, help="The lab (NN) this autograder grades.")
def autograder_run(root: Path, lab: str) -> None:
    """Grade one Gradescope submission (the autograder zip's run_autograder calls this)."""
    from pendkit.grading.gradescope import run

    result = run(root, lab)
    click.echo(f"score {result['score']:g}", err=True)


COMMANDS = (labs, grade, autograder_run)
