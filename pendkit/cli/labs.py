"""`pendkit labs build/check`, `pendkit grade` and `pendkit autograder-run` (Gradescope's per-submission entry)."""

from __future__ import annotations

import math
from pathlib import Path

import click

from pendkit.errors import ConfigError
from pendkit.grading.core import kit_hidden_tests, known_labs
from pendkit.grading.gradescope import build_autograder, run
from pendkit.grading.on_rigs import RigQueue
from pendkit.grading.sandbox import isolation_problem
from pendkit.queue.client import read_token_file

# pendkit modules that load nbformat are imported inside the functions that use them: importing this module does not
# need them (`pendkit --help` stays quick).


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
    if value is not None and value not in known_labs():
        raise click.BadParameter(f"the kit has no lab {value!r}: its labs are {', '.join(known_labs())}")
    return value


@click.command()
@click.argument("submissions", type=click.Path(exists=True, path_type=Path), required=False)
@click.option("--lab", default=None, callback=_lab, help="Grade only this lab (NN); default: from each notebook.")
@click.option("--gradescope-autograder", "autograder_zip", type=click.Path(dir_okay=False, path_type=Path),
              default=None, help="Instead of grading: write Gradescope's autograder zip for --lab NN.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("grades"),
              show_default=True, help="Where results.json files and grades.csv go.")
@click.option("--hidden", "hidden_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Hidden tests (labNN_*.py); default: the solutions/tests of the kit this command runs from.")
@click.option("--public-only", is_flag=True,
              help="Grade, or build the autograder, with the public tests only (scores out of fewer points).")
@click.option("--no-sandbox", is_flag=True,
              help="Grade a class where no sandbox can hold students' code (macOS, Windows, Linux without "
                   "bubblewrap): one submission can then change other students' grades.")
@click.option("--cell-timeout", type=float, default=120.0, show_default=True, callback=_seconds,
              help="Seconds per cell.")
@click.option("--notebook-timeout", type=float, default=600.0, show_default=True, callback=_seconds,
              help="Seconds per notebook.")
@click.option("--check-timeout", type=float, default=None, callback=_seconds,
              help="Cap on each test's own time limit, in seconds (default: the test's, usually 10).")
@click.option("--jobs", type=click.IntRange(1, 64), default=1, show_default=True,
              help="Notebooks graded at once (each runs its own kernel: about one core each).")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@click.option("--queue-server", default=None, metavar="URL",
              help="Judge the tasks judged on a rig (lab 10's 10.deploy) on the rigs of this `pendkit queue serve`, "
                   "as the instructor (token: PENDKIT_QUEUE_TOKEN or --queue-token-file); default: on the twin.")
@click.option("--queue-db", default=None, metavar="URL",
              help="The same through the queue's database (an SQLite file or postgresql+psycopg://...), filed under "
                   "the instructor's team, for the runners serving it.")
@click.option("--queue-token-file", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=None,
              help="With --queue-server: the instructor's login file (broker/logins/instructor.txt).")
@click.option("--queue-tls-ca", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=None,
              help="With an https --queue-server: the classroom CA (broker/ca.crt).")
@click.option("--queue-wait-minutes", type=click.FloatRange(min=0, min_open=True), default=120.0, show_default=True,
              help="How long to wait for the rigs' last verdict once every notebook is graded.")
@click.pass_context
def grade(ctx: click.Context, submissions: Path | None, lab: str | None, autograder_zip: Path | None, out_dir: Path,
          hidden_dir: Path | None, public_only: bool, no_sandbox: bool, cell_timeout: float, notebook_timeout: float,
          check_timeout: float | None, jobs: int, quiet: bool, queue_server: str | None, queue_db: str | None,
          queue_token_file: Path | None, queue_tls_ca: Path | None, queue_wait_minutes: float) -> None:
    """Run and grade every submitted notebook; write Gradescope results.json files and a CSV."""
    from pendkit.grading.report import grade_folder

    if hidden_dir is not None and not any(hidden_dir.glob("lab??_*.py")):
        raise click.BadParameter(f"{hidden_dir} holds no hidden tests (labNN_*.py)", param_hint="--hidden")
    hidden = None if public_only else (hidden_dir or kit_hidden_tests())
    if hidden is None and not public_only:
        raise click.UsageError("this install of pendkit has no hidden tests (solutions/tests: a clone installed "
                               "with `pip install -e .` has them): pass --hidden FOLDER, or --public-only to grade "
                               "out of the public points alone")
    public_note = "graded with the public tests only (--public-only): every score is out of the public points"
    if autograder_zip is not None:
        if lab is None:
            raise click.BadParameter("say which lab the autograder is for", param_hint="--lab")
        click.echo(f"wrote {build_autograder(autograder_zip, lab, hidden)} with "
                   + (f"the hidden tests of {hidden}" if hidden else "the public tests only")
                   + ": upload it as the assignment's autograder (docs/labs-and-grading.md)")
        return
    if submissions is None:
        raise click.BadParameter("give the folder of submitted notebooks", param_hint="SUBMISSIONS")
    if submissions.is_file():
        raise click.BadParameter(f"{submissions} is one notebook: pass the folder that holds it (its notebooks "
                                 "are all graded) or a folder with only this one in it", param_hint="SUBMISSIONS")
    if hidden is None:
        click.echo(public_note, err=True)
    if no_sandbox:
        click.echo(f"WARNING: no sandbox ({isolation_problem() or 'turned off by --no-sandbox'}): students' code "
                   "runs as you, with your files and network, and one submission can change other students' "
                   "grades.", err=True)
    rig_queue = _rig_queue(queue_server, queue_db, queue_token_file, queue_tls_ca, queue_wait_minutes)
    grades = grade_folder(submissions, out_dir, lab, hidden, cell_timeout, notebook_timeout, check_timeout,
                          progress=not quiet, jobs=jobs, isolate=False if no_sandbox else None, rig_queue=rig_queue)
    if not grades:
        raise click.ClickException(f"no notebooks found in {submissions}")
    for result in grades:
        click.echo(f"{result.student:<24} lab {result.lab}  {result.score:g}/{result.max_score:g}"
                   + (f"  ({len(result.notes)} notes)" if result.notes else ""))
    click.echo(f"reports: {out_dir / 'grades.csv'} and {out_dir}/<student>/results.json")
    for result in grades:
        for note in result.notes:
            if "CHECK:" in note:
                click.echo(note[note.index("CHECK:"):], err=True)
    if hidden is None:  # said again at the end, where an instructor reads the scores
        click.echo(f"NOTE: {public_note}", err=True)


def _rig_queue(server: str | None, db: str | None, token_file: Path | None, tls_ca: Path | None,
               wait_minutes: float):
    """The queue that judges rig tasks, checked before any notebook runs; None without one. The token leaves
    this process's environment first: no grading worker inherits it (students' kernels get a short list)."""
    import os

    token = os.environ.pop("PENDKIT_QUEUE_TOKEN", None)
    if server is None and db is None:
        if token_file is not None or tls_ca is not None:
            raise click.UsageError("--queue-token-file and --queue-tls-ca go with --queue-server")
        return None
    if server is not None and db is not None:
        raise click.UsageError("give --queue-server or --queue-db, not both")
    if token_file is not None:
        if token is not None:
            raise click.UsageError("the token comes from PENDKIT_QUEUE_TOKEN or --queue-token-file, not both")

        token = read_token_file(token_file)
    try:
        queue = RigQueue(server=server, db=db, token=token if server is not None else None,
                         tls_ca=str(tls_ca) if tls_ca is not None else None, wait_s=wait_minutes * 60)
        queue.check_reachable()
    except ConfigError as error:
        raise click.ClickException(str(error)) from None
    click.echo(f"tasks judged on a rig go to the queue at {queue.where} once every notebook is graded", err=True)
    return queue


@click.command("autograder-run")
@click.option("--root", type=click.Path(exists=True, file_okay=False, path_type=Path), default=Path("/autograder"),
              show_default=True, help="Gradescope's autograder folder.")
@click.option("--lab", required=True, callback=_lab, help="The lab (NN) this autograder grades.")
def autograder_run(root: Path, lab: str) -> None:
    """Grade one Gradescope submission (the autograder zip's run_autograder calls this)."""

    result = run(root, lab)
    click.echo(f"score {result['score']:g}", err=True)


COMMANDS = (labs, grade, autograder_run)
