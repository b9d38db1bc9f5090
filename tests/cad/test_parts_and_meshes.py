"""Printed parts from RigParams: valid solids, the tip weight's mass, the coupler's fit, an assembly without
overlaps, the same geometry in the twin, files that are current, the BOM's filament."""

import json
from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh
from click.testing import CliRunner

from pendkit.bom import read_bom
from pendkit.cad.assembly import ASSEMBLY_ORDER, export, overlaps_mm3, part_masses_g, to_stl_bytes
from pendkit.cad.parts import PRINTED_PARTS, PrintSettings, bore_diameter_mm, tip_weight_mass_g
from pendkit.cad.twin_meshes import visual_twin_model
from pendkit.cli import main
from pendkit.rig import RigParams
from pendkit.sim.model import build_model

ROOT = Path(__file__).resolve().parents[2]
PARAMS = RigParams()


@pytest.mark.parametrize("name", list(PRINTED_PARTS))
def test_every_part_is_a_closed_valid_solid(name):
    part = PRINTED_PARTS[name](PARAMS, PrintSettings())
    assert part.status().name == "NoError" and not part.is_empty() and part.volume() > 1000  # > 1 cm^3
    mesh = trimesh.load(trimesh.util.wrap_as_stream(to_stl_bytes(part)), file_type="stl")
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.is_volume
    assert mesh.volume == pytest.approx(part.volume(), rel=1e-6)


def test_the_tip_weight_at_its_infill_weighs_what_rigparams_says():
    settings = PrintSettings()
    assert tip_weight_mass_g(PARAMS, settings) == pytest.approx(PARAMS.tip_mass_kg * 1000, rel=0.05)
    solid = tip_weight_mass_g(PARAMS, PrintSettings(infill=1.0))
    assert solid > 1.5 * PARAMS.tip_mass_kg * 1000  # a solid print would be far too heavy: infill matters


@pytest.mark.parametrize("clearance_mm", [0.1, 0.2, 0.3])
def test_the_couplers_socket_is_the_dowel_plus_the_clearance(clearance_mm):
    settings = PrintSettings(bore_clearance_mm=clearance_mm)
    expected = PARAMS.dowel_diameter_m * 1000 + 2 * clearance_mm
    assert bore_diameter_mm(PARAMS, settings) == pytest.approx(expected, abs=0.02)
    thinner = RigParams(dowel_diameter_m=0.006)
    assert bore_diameter_mm(thinner, settings) == pytest.approx(6 + 2 * clearance_mm, abs=0.02)


def test_the_assembled_parts_do_not_overlap():
    clashes = {pair: volume for pair, volume in overlaps_mm3(PARAMS).items() if volume > 1e-3}
    assert clashes == {}


def test_an_encoder_where_the_mount_does_not_expect_it_is_caught():
    """The twin puts the encoder body at encoder_inset_m; the mount's plate must agree."""
    clashes = overlaps_mm3(RigParams(encoder_inset_m=0.017))
    assert clashes[("encoder_mount", "encoder_body")] > 100


def test_the_twins_physics_compiles_without_cad_and_drawing_adds_no_mass():
    physics, drawn = build_model(PARAMS), visual_twin_model(PARAMS)
    assert physics.nmesh == 0 and drawn.nmesh == len(PRINTED_PARTS)
    np.testing.assert_allclose(drawn.body_mass, physics.body_mass)
    np.testing.assert_allclose(drawn.body_inertia, physics.body_inertia)
    assert [drawn.joint(k).name for k in range(drawn.njnt)] == [physics.joint(k).name for k in range(physics.njnt)]


def test_the_twin_draws_the_printed_parts_with_the_same_meshes_and_no_extra_mass():
    model = visual_twin_model(RigParams(tip_diameter_m=0.05))
    vertices = model.mesh_vert[model.mesh_vertadr[model.mesh("tip_weight").id]:][:model.mesh_vertnum[
        model.mesh("tip_weight").id]]
    # MuJoCo turns a mesh to its principal axes: the extents, sorted, are height, diameter, diameter (m).
    np.testing.assert_allclose(np.sort(np.ptp(vertices, axis=0)), [0.012, 0.05, 0.05], rtol=1e-3)
    for name in PRINTED_PARTS:
        geom = model.geom(f"{name}_print")
        assert geom.contype == 0 and geom.conaffinity == 0
    pendulum = build_model(PARAMS).body("pendulum").id
    expected = PARAMS.coupler_mass_kg + PARAMS.dowel_mass_kg + PARAMS.tip_mass_kg
    assert build_model(PARAMS).body_mass[pendulum] == pytest.approx(expected, rel=1e-9)


def test_the_twins_tip_weight_sits_where_the_print_does():
    model = visual_twin_model(PARAMS)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    drawn = data.geom_xpos[model.geom("tip_weight_print").id]
    lumped = data.geom_xpos[model.geom("tip_weight").id]
    np.testing.assert_allclose(drawn, lumped, atol=2e-4)  # mesh centroid vs the inertial cylinder


def test_the_committed_stl_files_are_current(tmp_path):
    export(tmp_path, PARAMS)
    for name in PRINTED_PARTS:
        committed = ROOT / "hardware_bom" / "cad" / f"{name}.stl"
        assert committed.read_bytes() == (tmp_path / f"{name}.stl").read_bytes(), \
            f"{committed} is stale: run `pendkit cad --out hardware_bom/cad`"


def test_the_bom_buys_enough_filament_for_the_parts():
    printed = sum(part_masses_g(PARAMS).values())
    line = next(line for line in read_bom(ROOT / "hardware_bom" / "bom.csv") if line.part == "Printed parts")
    assert line.quantity * 1000 >= printed  # kilograms of filament against grams printed


def test_the_build_guide_names_every_part_file_in_its_assembly_order():
    guide = (ROOT / "docs" / "build-guide.md").read_text()
    assembly = guide[guide.index("## Assembly"):guide.index("## Flashing")]
    for name in PRINTED_PARTS:
        assert f"`{name}.stl`" in assembly
    assert "kill switch" in guide[guide.index("## Safety"):].lower()
    assert [step for step, _ in ASSEMBLY_ORDER if step in PRINTED_PARTS] == \
        sorted(PRINTED_PARTS, key=lambda name: assembly.index(f"`{name}.stl`"))


def test_pendkit_cad_writes_stl_files_and_a_summary(tmp_path):
    result = CliRunner().invoke(main, ["cad", "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "parts.json").read_text())
    assert set(summary["parts"]) == set(PRINTED_PARTS) and summary["units"] == "mm"
    assert "filament per rig" in result.output


def test_the_views_for_the_build_guide_render(tmp_path):
    """In a fresh process (MuJoCo picks its GL backend when first imported): `pendkit cad --render`."""
    import subprocess
    import sys

    probe = subprocess.run([sys.executable, "-c", "from pendkit.sim.render import mujoco_renderer\n"
                            "import mujoco\n"
                            "m = mujoco.MjModel.from_xml_string('<mujoco/>')\n"
                            "raise SystemExit(0 if mujoco_renderer(m) is not None else 3)"], capture_output=True)
    if probe.returncode == 3:
        pytest.skip("no OpenGL backend for MuJoCo here")
    result = subprocess.run([sys.executable, "-m", "pendkit.cli", "cad", "--out", str(tmp_path / "stl"),
                             "--render", str(tmp_path / "img")], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    from PIL import Image

    images = sorted((tmp_path / "img").glob("cad-*.png"))
    assert len(images) == 6
    image = np.asarray(Image.open(images[0]))
    assert image.shape == (560, 800, 3) and image.std() > 5  # not a blank frame
