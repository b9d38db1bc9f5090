"""The classical controllers' registry (`pendkit.deploy.controllers`): each module registers a controller that
runs from the laptop and on the device, and everything that lists controllers reads the registry."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

import pendkit
from pendkit.deploy.controllers import CONTROLLER_NAMES, DEFAULT_CONTROLLER, adapt_controllers, controller_named
from pendkit.device.controller_blob import pack, parse
from pendkit.episode import run_episode
from pendkit.errors import ConfigError
from pendkit.features import holds_upright
from pendkit.rig import RigParams

TAIL_STEPS = 200


def _twin(**kwargs):
    return pendkit.make(action_mode="continuous", fidelity="realistic", filter_coefficient=0.0, **kwargs)


def test_the_registry_finds_every_module_and_refuses_an_unknown_name():
    assert CONTROLLER_NAMES[0] == DEFAULT_CONTROLLER
    assert {"energy", "trajopt", "pole-placement"} <= set(CONTROLLER_NAMES)
    for name in CONTROLLER_NAMES:
        controller = controller_named(name)
        assert controller.name == name and controller.label and controller.title
    with pytest.raises(ConfigError, match="pole-placement"):
        controller_named("pid")
    assert [c.name for c in adapt_controllers()] == ["energy", "trajopt"]  # adapt's cost does not grow by itself


@pytest.mark.parametrize("name", CONTROLLER_NAMES)
def test_every_controller_designs_a_blob_the_device_takes(name):
    from pendkit.deploy.swingup_design import design_swing_up

    blob = design_swing_up(RigParams.preset("turnigy-tgy-wp23"), name)
    assert blob.kind == controller_named(name).blob_kind
    assert parse(pack(blob)).kind == blob.kind and np.all(np.isfinite(blob.balance_gain))


def test_the_command_line_offers_what_the_registry_holds():
    from pendkit.cli import main

    for command in (["demo"], ["eval"], ["export"], ["deploy"], ["queue", "submit"]):
        text = CliRunner().invoke(main, [*command, "--help"], terminal_width=200).output
        assert all(name in text for name in CONTROLLER_NAMES), command


def test_pole_placement_catches_from_the_laptop_and_on_the_device():
    """The controller added as one module: its catch is not the LQR's, and it swings the twin up both ways."""
    from pendkit.control.swingup import SwingUpController
    from pendkit.deploy.on_twin import onboard_episode, upload_to_twin
    from pendkit.deploy.swingup_design import design_swing_up

    env = _twin(start="rest")
    placed = controller_named("pole-placement").host(env)
    assert not np.allclose(placed.balancer.gain, SwingUpController.for_env(env).balancer.gain, rtol=0.05)
    trace = run_episode(env, placed, seed=3)
    assert holds_upright(trace.pendulum_from_upright_rad, TAIL_STEPS)
    upload_to_twin(env, pack(design_swing_up(env.unwrapped.params, "pole-placement")))
    angles = onboard_episode(env, seed=4, start="rest")
    assert holds_upright(angles, TAIL_STEPS)
    env.close()


@pytest.mark.expensive
def test_pole_placement_is_solved_by_the_kits_rule_on_the_twin():
    from pendkit.cli import main

    result = CliRunner().invoke(main, ["eval", "--controller", "pole-placement", "--episodes", "10"])
    assert result.exit_code == 0, result.output
    solved = int(result.output.split("controller_solved=")[1].split("/")[0])
    assert solved >= 9, result.output
