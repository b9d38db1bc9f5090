"""The whole path a team sees: a job submitted over HTTP, run by the runner on a virtual rig (the twin as a rig,
at 20x), followed on the public state and read back by its team: the verdict, the telemetry and the plot."""

import csv
import io

import pytest

from tests.queue.runner_rigs import SPEED, STEPS, serving
from tests.queue.serving import TOKENS, served_queue

pytest.importorskip("sqlalchemy")


@pytest.mark.expensive
def test_a_job_submitted_over_http_is_run_on_a_rig_and_read_back_by_its_team(tmp_path):
    from pendkit.queue.client import QueueClient, QueueRequestError
    from pendkit.queue.runner import QueueRunner
    from pendkit.queue.virtual import VirtualRigs

    with served_queue(tmp_path) as queue, VirtualRigs(["r01"], SPEED) as rigs:
        team = QueueClient(queue.url, token=TOKENS["team-a"])
        job_id = team.submit_controller("energy", episodes=1, episode_steps=STEPS)
        assert team.state()["jobs"] == [{"id": job_id, "team": "team-a", "kind": "controller", "state": "waiting",
                                         "rig": None, "place": 1}]
        states = []
        runner = QueueRunner(queue.store, rigs.links(), "bench-1", speed=SPEED, say=lambda line: None)
        with serving(runner):
            job = team.wait(job_id, timeout_s=600, poll_s=0.2, on_change=lambda j: states.append(j["state"]))
        assert states[0] == "waiting" and states[-1] == "done" and job["rig"] == "r01"
        # the page's figures are the runner's (whether the swing-up held on a loaded machine is the runner's tests')
        (episode,) = job["summary"]["episodes"]
        assert job["figures"]["episodes"] == 1 and job["figures"]["held"] == int(episode["held"])
        held = int(episode["held"])
        assert job["figures"]["verdict"] == f"{held}/1 held (fewer episodes than the rule's: not judged)"
        assert job["figures"]["time_to_upright_s"] == (episode["time_to_upright_s"] if episode["held"] else None)
        rows = list(csv.reader(io.StringIO(team.telemetry_csv(job_id))))
        assert len(rows) == STEPS + 1  # a header and a row per control step
        assert team.plot_png(job_id)[:8] == b"\x89PNG\r\n\x1a\n"
        assert {rig["rig"]: rig["state"] for rig in team.state()["rigs"]} == {"r01": "free"}

        other = QueueClient(queue.url, token=TOKENS["team-b"])
        with pytest.raises(QueueRequestError, match=f"no job {job_id} of team team-b"):
            other.plot_png(job_id)
