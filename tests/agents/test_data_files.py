"""Weights and checkpoints are read as data: a crafted file runs no code, a broken one is named in one line."""

import pickle

import numpy as np
import pytest
import torch
from click.testing import CliRunner

from pendkit.agents.data_files import load_data, save_data
from pendkit.agents.runs import RunSpec, build_run, load_weights, save_weights
from pendkit.cli import main
from pendkit.errors import ConfigError


class RunsCode:
    """What a crafted weights file holds: unpickling it would call `marker.write_text`."""

    def __init__(self, marker) -> None:
        self.marker = marker

    def __reduce__(self):
        return (self.marker.write_text, ("code ran",))


def crafted_run(folder, marker):
    folder.mkdir()
    torch.save({"format": "pendkit-weights/1", "spec": RunSpec().to_dict(), "agent": RunsCode(marker)},
               folder / "final.pt")
    return folder


def test_a_crafted_weights_file_runs_no_code_and_is_refused_naming_it(tmp_path):
    marker = tmp_path / "pwned.txt"
    run = crafted_run(tmp_path / "run", marker)
    with pytest.raises(ConfigError, match="final.pt is not a weights file the kit reads as data"):
        load_weights(run / "final.pt")
    result = CliRunner().invoke(main, ["eval", str(run)])
    assert result.exit_code == 1 and "final.pt" in result.output and "Traceback" not in result.output
    assert not marker.exists()


@pytest.mark.parametrize("content", [b"", b"PK\x03\x04 truncated", b"not a weights file at all"])
def test_a_truncated_or_empty_weights_file_is_named_in_one_line(tmp_path, content):
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "final.pt").write_bytes(content)
    result = CliRunner().invoke(main, ["eval", str(tmp_path / "run")])
    assert result.exit_code == 1, result.output
    assert "final.pt is not a readable weights file" in result.output
    assert len(result.output.strip().splitlines()) == 1


def test_numpy_state_round_trips_as_data(tmp_path):
    value = {"arrays": {"x": np.arange(6, dtype=np.float32).reshape(2, 3), "done": np.array([True, False]),
                        "key": np.arange(4, dtype=np.uint32)},
             "rng": np.random.default_rng(1).bit_generator.state, "count": np.int64(7), "legacy": np.random.get_state()}
    back = load_data(save_data(tmp_path / "state.pt", value))
    assert back["arrays"]["x"].dtype == np.float32 and np.array_equal(back["arrays"]["x"], value["arrays"]["x"])
    assert back["arrays"]["key"].dtype == np.uint32 and back["count"] == 7 and type(back["count"]) is int
    assert back["rng"] == value["rng"] and np.array_equal(back["legacy"][1], value["legacy"][1])


def test_a_saved_agent_loads_back_with_weights_only(tmp_path):
    env, agent, _ = build_run(RunSpec("r-dqn", "ideal", max_steps=20))
    path = save_weights(tmp_path / "w.pt", agent, RunSpec("r-dqn", "ideal"))
    torch.load(path, weights_only=True)  # loads under torch's own data-only rule
    spec, state = load_weights(path)
    assert spec.learner == "r-dqn" and pickle.dumps(state)  # plain data
