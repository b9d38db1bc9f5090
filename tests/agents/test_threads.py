"""The kit's torch work runs on one thread per process unless told otherwise."""

import os
import subprocess
import sys

import pytest

BUILD = "import torch\nfrom pendkit.agents.nets import mlp\nmlp(4, 3, (8,))\nprint(torch.get_num_threads())"


def threads_after_building_a_network(**variables) -> subprocess.CompletedProcess:
    environment = {k: v for k, v in os.environ.items() if k != "PENDKIT_TORCH_THREADS"}
    environment.update(OMP_NUM_THREADS="2", **variables)  # torch's own default would be 2 threads
    return subprocess.run([sys.executable, "-c", BUILD], env=environment, capture_output=True, text=True)


def test_one_thread_by_default_where_torch_would_take_two():
    run = threads_after_building_a_network()
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "1"


def test_the_variable_overrides_the_default():
    run = threads_after_building_a_network(PENDKIT_TORCH_THREADS="2")
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "2"


@pytest.mark.parametrize("bad", ["0", "two", "-1"])
def test_a_bad_thread_count_is_named_in_the_error(bad):
    run = threads_after_building_a_network(PENDKIT_TORCH_THREADS=bad)
    assert run.returncode != 0
    assert "PENDKIT_TORCH_THREADS" in run.stderr and repr(bad) in run.stderr
