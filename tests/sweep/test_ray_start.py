"""A local Ray whose node misses Ray's fixed 30 s to start (a laptop busy with other work) is started once more,
and the user is told why; any other failure, a second miss, or a cluster address is not retried."""

import pytest

ray = pytest.importorskip("ray", reason='the sweep needs the cluster extra: pip install -e ".[cluster]"')

from pendkit.sweep import ray_runner  # noqa: E402

TIMED_OUT = "The current node timed out during startup. This could happen because some of the raylet failed"


def failing_init(failures: list[str], monkeypatch) -> list[dict]:
    """Ray's init raising each of `failures` in turn, then starting no cluster (the calls it got)."""
    calls: list[dict] = []

    def init(**kwargs):
        calls.append(kwargs)
        if len(calls) <= len(failures):
            raise Exception(failures[len(calls) - 1])  # noqa: TRY002 - Ray raises exactly this

    monkeypatch.setattr(ray, "init", init)
    monkeypatch.setattr(ray, "shutdown", lambda: None)
    monkeypatch.setattr(ray, "nodes", lambda: [{"Alive": True}])
    monkeypatch.setattr(ray, "cluster_resources", lambda: {"CPU": 2})
    return calls


def test_a_local_node_that_missed_its_start_is_started_once_more(monkeypatch):
    calls, said = failing_init([TIMED_OUT], monkeypatch), []
    ray_runner.start_ray(num_cpus=2, say=said.append)
    assert len(calls) == 2 and "starting it once more" in said[0] and said[-1].startswith("Ray up in")


def test_a_second_miss_another_failure_or_a_cluster_is_not_retried(monkeypatch):
    for failures, address in (([TIMED_OUT] * 2, None), (["no such cluster"], None), ([TIMED_OUT], "10.0.0.1:6379")):
        calls = failing_init(failures, monkeypatch)
        with pytest.raises(Exception, match="timed out during startup|no such cluster"):
            ray_runner.start_ray(address=address, say=lambda line: None)
        assert len(calls) == (2 if len(failures) == 2 else 1)
