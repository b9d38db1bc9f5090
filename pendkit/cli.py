"""The `pendkit` command: thin subcommands over library calls."""

from __future__ import annotations

import json
import platform
import sys
from pathlib import Path

import click

from pendkit.sim.fidelity import FIDELITY_PRESETS

FIDELITIES = tuple(FIDELITY_PRESETS)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="pendkit", message="pendkit %(version)s")
def main() -> None:
    """pendkit: the swing-up pendulum teaching kit (twin, rig link, labs, grader)."""


@main.command()
@click.option("--fidelity", type=click.Choice(FIDELITIES), default="realistic", show_default=True,
              help="How closely the twin imitates the real rig.")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the episode's start state.")
@click.option("--start", type=click.Choice(("rest", "random")), default="rest", show_default=True,
              help="Start hanging still, or from the authors' random state.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("pendkit-output"), show_default=True, help="Where to write the plot and animation.")
@click.option("--no-animation", is_flag=True, help="Skip the GIF.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@click.option("--controller", type=click.Choice(("energy", "trajopt")), default="energy", show_default=True,
              help="Energy pumping, or the minimum-time plan tracked by time-varying LQR.")
def demo(fidelity: str, seed: int, start: str, out_dir: Path, no_animation: bool, quiet: bool,
         controller: str) -> None:
    """Swing up and balance on the MuJoCo twin (energy or minimum-time swing-up + LQR); save a plot and a GIF."""
    import warnings

    from pendkit.demo import run_demo

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # no GL here: frames are drawn instead
        result = run_demo(fidelity, seed, start, out_dir, progress=not quiet, animate=not no_animation,
                          controller_name=controller)
    trace = result.trace
    upright = (f"upright after {result.time_to_upright_s:.2f} s and to the end"
               if result.time_to_upright_s is not None else "not upright at the end")
    click.echo(f"{len(trace.time_s) - 1} steps, {trace.time_s[-1]:.1f} s simulated, return "
               f"{trace.episode_return:.1f}, {upright}")
    click.echo(f"plot: {result.plot_path}")
    if result.animation_path is not None:
        click.echo(f"animation: {result.animation_path}")


@main.command()
@click.option("--json", "as_json", is_flag=True, help="Machine-readable output.")
@click.option("--preset", default="hitec-d645mw", show_default=True, help="Rig preset to show.")
def info(as_json: bool, preset: str) -> None:
    """Versions, the GL backend for rendering, and the rig's parameters."""
    import pendkit
    from pendkit.errors import ConfigError

    try:
        params = pendkit.RigParams.preset(preset)
    except ConfigError as error:
        raise click.BadParameter(str(error), param_hint="--preset") from None
    report = {
        "pendkit": pendkit.__version__,
        "python": platform.python_version(),
        "platform": platform.platform(),
        "packages": _versions(("numpy", "mujoco", "gymnasium", "control", "paho-mqtt", "matplotlib", "torch")),
        "gl_backend": _gl_status(),
        "rig": {"preset": preset, **params.to_dict()},
        "derived": {
            "frame_skip": params.frame_skip,
            "servo_speed_rad_s": round(params.servo_speed_rad_s, 4),
            "servo_stall_torque_n_m": round(params.servo_stall_torque_n_m, 4),
            "pendulum_natural_frequency_rad_s": round(params.pendulum_natural_frequency_rad_s, 4),
            "small_oscillation_period_s": round(2 * 3.141592653589793
                                                / params.pendulum_natural_frequency_rad_s, 4),
        },
    }
    if as_json:
        click.echo(json.dumps(report, indent=2))
        return
    click.echo(f"pendkit {report['pendkit']} on Python {report['python']} ({report['platform']})")
    for name, ver in report["packages"].items():
        click.echo(f"  {name:<11} {ver}")
    click.echo(f"rendering: {report['gl_backend']}")
    click.echo(f"rig preset {preset}:")
    for name, value in {**report["rig"], **report["derived"]}.items():
        click.echo(f"  {name:<34} {value}")


@main.group()
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


@main.command()
@click.argument("submissions", type=click.Path(exists=True, file_okay=False, path_type=Path), required=False)
@click.option("--lab", default=None, help="Grade only this lab (NN); default: from each notebook.")
@click.option("--gradescope-autograder", "autograder_zip", type=click.Path(dir_okay=False, path_type=Path),
              default=None, help="Instead of grading: write Gradescope's autograder zip for --lab NN.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("grades"),
              show_default=True, help="Where results.json files and grades.csv go.")
@click.option("--hidden", "hidden_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("solutions/tests"), show_default=True, help="Hidden tests (labNN_*.py).")
@click.option("--cell-timeout", type=float, default=120.0, show_default=True, help="Seconds per cell.")
@click.option("--notebook-timeout", type=float, default=600.0, show_default=True, help="Seconds per notebook.")
@click.option("--check-timeout", type=float, default=None,
              help="Cap on each test's own time limit, in seconds (default: the test's, usually 10).")
@click.option("--jobs", type=click.IntRange(1, 64), default=1, show_default=True,
              help="Notebooks graded at once (each runs its own kernel: about one core each).")
@click.option("--quiet", is_flag=True, help="No progress bar.")
def grade(submissions: Path | None, lab: str | None, autograder_zip: Path | None, out_dir: Path, hidden_dir: Path,
          cell_timeout: float, notebook_timeout: float, check_timeout: float | None, jobs: int, quiet: bool) -> None:
    """Run and grade every submitted notebook; write Gradescope results.json files and a CSV."""
    from pendkit.grading.report import grade_folder
    from pendkit.grading.sandbox import isolation_problem

    if lab is not None and not (len(lab) == 2 and lab.isdigit()):
        raise click.BadParameter(f"expected two digits such as 01, got {lab!r}", param_hint="--lab")
    hidden = hidden_dir if hidden_dir.exists() else None
    if hidden is None:
        click.echo(f"no hidden tests at {hidden_dir}: grading with public tests only", err=True)
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


@main.command()
@click.argument("csv_path", type=click.Path(exists=True, dir_okay=False, path_type=Path),
                default=Path("hardware_bom/bom.csv"))
@click.option("--rigs", type=click.IntRange(1, 1000), default=10, show_default=True, help="Rigs in the class.")
def bom(csv_path: Path, rigs: int) -> None:
    """Check the bill of materials and print its cost per rig and for a class."""
    from pendkit.bom import cost_summary, read_bom
    from pendkit.errors import ConfigError

    try:
        click.echo(cost_summary(read_bom(csv_path), rigs))
    except ConfigError as error:
        raise click.ClickException(str(error)) from None


@main.command()
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("pendkit-cad"),
              show_default=True, help="Where to write the STL files and parts.json.")
@click.option("--preset", default=None, help="A RigParams preset (see `pendkit info`); default the paper's rig.")
@click.option("--render", "render_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Also draw the assembled and exploded views into this folder (needs OpenGL).")
def cad(out_dir: Path, preset: str | None, render_dir: Path | None) -> None:
    """Write the printed parts as STL (mm) from RigParams, check they fit together, print their masses."""
    from pendkit.cad.assembly import export, overlaps_mm3
    from pendkit.errors import ConfigError
    from pendkit.rig import RigParams

    try:
        params = RigParams.preset(preset) if preset else RigParams()
    except ConfigError as error:
        raise click.ClickException(str(error)) from None
    clashes = {pair: volume for pair, volume in overlaps_mm3(params).items() if volume > 1e-3}
    if clashes:
        raise click.ClickException(f"parts overlap (mm^3): {clashes}")
    written = export(out_dir, params)
    summary = json.loads(written[-1].read_text())
    for part in summary["parts"].values():
        click.echo(f"{part['file']:<20} {part['size_mm'][0]:6.1f} x {part['size_mm'][1]:5.1f} x "
                   f"{part['size_mm'][2]:5.1f} mm  {part['printed_mass_g']:5.1f} g")
    click.echo(f"filament per rig: {summary['filament_per_rig_g']:.0f} g; written to {out_dir}/")
    if render_dir is not None:
        from pendkit.cad.render import render

        try:
            for path in render(params, render_dir):
                click.echo(f"view: {path}")
        except ConfigError as error:
            raise click.ClickException(str(error)) from None


@main.command()
@click.option("--pins", "pins_path", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              default=Path("firmware/include/pins.h"), show_default=True, help="The firmware's pin map.")
@click.option("--out", "out_path", type=click.Path(dir_okay=False, path_type=Path),
              default=Path("docs/img/wiring.png"), show_default=True)
def wiring(pins_path: Path, out_path: Path) -> None:
    """Draw the rig's wiring diagram from the firmware's pin map."""
    from pendkit.wiring import draw_wiring

    click.echo(f"wiring diagram: {draw_wiring(pins_path, out_path)}")


def _versions(names) -> dict[str, str]:
    from importlib.metadata import PackageNotFoundError, version

    found = {}
    for name in names:
        try:
            found[name] = version(name)
        except PackageNotFoundError:
            found[name] = "not installed"
    return found


def _gl_status() -> str:
    import os
    import warnings

    import pendkit  # noqa: F401  (chooses MUJOCO_GL before mujoco loads)
    from pendkit.sim.model import build_model
    from pendkit.sim.render import mujoco_renderer

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        renderer = mujoco_renderer(build_model(pendkit.RigParams()), 64, 48)
    backend = os.environ.get("MUJOCO_GL", "default")
    if renderer is None:
        return f"MuJoCo {backend} unavailable: frames are drawn with matplotlib"
    renderer.close()
    return f"MuJoCo offscreen ({backend})"


def _register_commands() -> None:
    from pendkit.agents.cli import evaluate, plot, train
    from pendkit.link.cli import broker, broker_config, virtual_rig

    for command in (broker, broker_config, virtual_rig, train, evaluate, plot):
        main.add_command(command)


_register_commands()

if __name__ == "__main__":
    sys.exit(main())
