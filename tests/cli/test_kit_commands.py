import json

from click.testing import CliRunner

from pendkit.cli import main


def test_help_everywhere():
    runner = CliRunner()
    names = [[]] + [[name] for name in main.commands] + [["labs", "build"], ["labs", "check"]]
    assert {"demo", "info", "grade", "train", "eval", "plot", "virtual-rig", "broker"} <= set(main.commands)
    for args in names:
        result = runner.invoke(main, [*args, "--help"])
        assert result.exit_code == 0 and "Usage" in result.output, args


def test_demo_swings_up_and_writes_a_plot_and_an_animation(tmp_path):
    result = CliRunner().invoke(main, ["demo", "--fidelity", "ideal", "--out", str(tmp_path), "--quiet"])
    assert result.exit_code == 0, result.output
    plot = tmp_path / "demo-ideal-seed0.png"
    assert plot.exists() and plot.read_bytes()[:4] == b"\x89PNG"
    gif = (tmp_path / "demo-ideal-seed0.gif").read_bytes()
    assert gif[:3] == b"GIF" and b"swinging up and balancing" in gif  # with its description
    from PIL import Image

    assert "Pendulum angle from upright" in Image.open(plot).info["Description"]  # the plot's alt text
    assert "500 steps" in result.output and "upright after" in result.output


def test_info_json_has_versions_and_rig():
    result = CliRunner().invoke(main, ["info", "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    assert report["rig"]["encoder_counts"] == 1024
    assert report["derived"]["frame_skip"] == 12
    assert "mujoco" in report["packages"] and report["gl_backend"]


def test_info_rejects_unknown_preset():
    result = CliRunner().invoke(main, ["info", "--preset", "nope"])
    assert result.exit_code == 2 and "unknown rig preset" in result.output


def test_demo_runs_the_minimum_time_swing_up_and_draws_its_plans(tmp_path):
    result = CliRunner().invoke(main, ["demo", "--fidelity", "ideal", "--controller", "trajopt", "--no-animation",
                                       "--out", str(tmp_path), "--quiet"])
    assert result.exit_code == 0, result.output
    plot = tmp_path / "demo-ideal-seed0-trajopt.png"
    from PIL import Image

    assert "Minimum-time swing-up" in Image.open(plot).info["Description"]
    upright_s = float(result.output.split("upright after ")[1].split(" s")[0])
    assert upright_s < 2.5  # energy pumping from rest on the ideal twin: 4.0 s
