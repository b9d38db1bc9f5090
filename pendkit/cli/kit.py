"""`pendkit demo`, `info`, `bom`, `cad`, `wiring`, `firmware-header`: the twin, the rig's facts, its parts."""

from __future__ import annotations

import json
import platform
from pathlib import Path

import click

from pendkit.bom import cost_summary, read_bom
from pendkit.demo import run_demo
from pendkit.deploy.controllers import CONTROLLER_NAMES
from pendkit.errors import ConfigError
from pendkit.firmware_constants import render_header
from pendkit.rig import RigParams
from pendkit.sim.fidelity import FIDELITY_PRESETS
from pendkit.sim.render import mujoco_renderer
from pendkit.wiring import draw_wiring

# pendkit modules that load MuJoCo and manifold3d are imported inside the functions that use them: importing this
# module does not need them (`pendkit --help` stays quick).

FIDELITIES = tuple(FIDELITY_PRESETS)


@click.command()
@click.option("--fidelity", type=click.Choice(FIDELITIES), default="realistic", show_default=True,
              help="How closely the twin imitates the real rig.")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the episode's start state.")
@click.option("--start", type=click.Choice(("rest", "random")), default="rest", show_default=True,
              help="Start hanging still, or from the authors' random state.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("pendkit-output"), show_default=True, help="Where to write the plot and animation.")
@click.option("--no-animation", is_flag=True, help="Skip the GIF.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@click.option("--controller", type=click.Choice(CONTROLLER_NAMES), default="energy", show_default=True,
              help="Energy pumping, or the minimum-time plan tracked by time-varying LQR.")
def demo(fidelity: str, seed: int, start: str, out_dir: Path, no_animation: bool, quiet: bool,
         controller: str) -> None:
    """Swing up and balance on the MuJoCo twin (energy or minimum-time swing-up + LQR); save a plot and a GIF."""
    import warnings

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


@click.command()
@click.option("--json", "as_json", is_flag=True, help="Machine-readable output.")
@click.option("--preset", default="hitec-d645mw", show_default=True, help="Rig preset to show.")
def info(as_json: bool, preset: str) -> None:
    """Versions, the GL backend for rendering, and the rig's parameters."""
    import pendkit

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


@click.command()
@click.argument("csv_path", type=click.Path(exists=True, dir_okay=False, path_type=Path),
                default=Path("hardware_bom/bom.csv"))
@click.option("--rigs", type=click.IntRange(1, 1000), default=10, show_default=True, help="Rigs in the class.")
def bom(csv_path: Path, rigs: int) -> None:
    """Check the bill of materials and print its cost per rig and for a class."""

    try:
        click.echo(cost_summary(read_bom(csv_path), rigs))
    except ConfigError as error:
        raise click.ClickException(str(error)) from None


@click.command()
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("pendkit-cad"),
              show_default=True, help="Where to write the STL files and parts.json.")
@click.option("--preset", default=None, help="A RigParams preset (see `pendkit info`); default the paper's rig.")
@click.option("--render", "render_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Also draw the assembled and exploded views into this folder (needs OpenGL).")
def cad(out_dir: Path, preset: str | None, render_dir: Path | None) -> None:
    """Write the printed parts as STL (mm) from RigParams, check they fit together, print their masses."""
    from pendkit.cad.assembly import export, overlaps_mm3

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


@click.command()
@click.option("--pins", "pins_path", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              default=Path("firmware/include/pins.h"), show_default=True, help="The firmware's pin map.")
@click.option("--out", "out_path", type=click.Path(dir_okay=False, path_type=Path),
              default=Path("docs/img/wiring.png"), show_default=True)
def wiring(pins_path: Path, out_path: Path) -> None:
    """Draw the rig's wiring diagram from the firmware's pin map."""

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

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        renderer = mujoco_renderer(build_model(pendkit.RigParams()), 64, 48)
    backend = os.environ.get("MUJOCO_GL", "default")
    if renderer is None:
        return f"MuJoCo {backend} unavailable: frames are drawn with matplotlib"
    renderer.close()
    return f"MuJoCo offscreen ({backend})"


@click.command("firmware-header")
@click.option("--preset", default=None, help="A servo preset (default: RigParams' defaults, the paper's D645MW).")
def firmware_header(preset: str | None) -> None:
    """Print the firmware's rig_constants.h, generated from RigParams (firmware/lib/pendcore/src)."""

    try:
        params = RigParams.preset(preset) if preset else None
    except ConfigError as error:
        raise click.BadParameter(str(error), param_hint="--preset") from None
    click.echo(render_header(params), nl=False)


COMMANDS = (demo, info, bom, cad, wiring, firmware_header)
