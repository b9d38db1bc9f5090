"""Lab 10's `10.deploy` graded by what a rig did: `pendkit grade --queue-server` (or `--queue-db`) submits each
student's own blob, checked by the device's parser first, as an instructor's job; virtual rigs served by a
runner judge it by the rule, and the verdict becomes the task's marks and feedback. Without a queue the twin
judges it and the feedback says so. The grader's token never reaches a student's kernel."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import nbformat
import pytest
from click.testing import CliRunner

from pendkit.cli import main
from pendkit.control.swingup import SwingUpConfig
from pendkit.deploy.swingup_design import design_swing_up
from pendkit.device.controller_blob import pack
from pendkit.queue.runner import QueueRunner
from pendkit.queue.store import QueueStore
from pendkit.queue.virtual import VirtualRigs
from pendkit.rig import RigParams
from tests.queue.runner_rigs import serving
from tests.queue.serving import TOKENS, served_queue
from tests.system_needs import no_sandbox_args

INSTRUCTOR_TOKEN = TOKENS["instructor"]
# a rule's job (10 episodes of 30 s and their resets) in about 80 s. The runner's reset keeps the wall clock
# times the speed: where grading kernels and other tests share 2 cores with the rigs, rigs at 20x, and once at
# 10x, fell behind it and were taken out of service for not settling
RIG_SPEED = 5.0
IMPORTS = """import os
import pendkit
from pendkit.control.swingup import SwingUpConfig
from pendkit.deploy.swingup_design import design_swing_up
from pendkit.device.controller_blob import pack"""
DEPLOYED = {  # each student's own deployed_blob()
    # the kit's minimum-time design; garbage instead if the grader's token is anywhere in this kernel's environment
    "alice": f"""LEAKED = "PENDKIT_QUEUE_TOKEN" in os.environ or any({INSTRUCTOR_TOKEN!r} in value
                                                      for value in os.environ.values())

def deployed_blob():
    if LEAKED:
        return b"the grader's token reached the student's kernel"
    return pack(design_swing_up(pendkit.RigParams(), "trajopt"))""",
    # pumps to 60% of the energy upright needs: never gets there
    "bob": """def deployed_blob():
    return pack(design_swing_up(pendkit.RigParams(), "energy", config=SwingUpConfig(target_energy=0.6)))""",
    # cut short: the device's parser refuses it, so it never reaches the queue
    "carol": """def deployed_blob():
    return pack(design_swing_up(pendkit.RigParams(), "energy"))[:-7]""",
}


def alice_blob() -> bytes:
    return pack(design_swing_up(RigParams(), "trajopt"))


def bob_blob() -> bytes:
    return pack(design_swing_up(RigParams(), "energy", config=SwingUpConfig(target_energy=0.6)))


def a_class(folder: Path, students: tuple[str, ...]) -> Path:
    for student in students:
        notebook = nbformat.v4.new_notebook()
        notebook.cells = [nbformat.v4.new_code_cell(IMPORTS), nbformat.v4.new_code_cell(DEPLOYED[student])]
        (folder / student).mkdir(parents=True)
        nbformat.write(notebook, folder / student / "10_on_device.ipynb")
    return folder


def deploy_feedback(out: Path, student: str) -> dict[str, dict]:
    """The 10.deploy tests of a student's results.json, by test name."""
    tests = json.loads((out / student / "results.json").read_text())["tests"]
    return {test["name"].rsplit(": ", 1)[1]: test for test in tests if test["name"].startswith("10.deploy ")}


def grade(folder: Path, out: Path, *queue_args: str, env: dict | None = None):
    return CliRunner().invoke(main, ["grade", str(folder), "--lab", "10", "--out", str(out), "--quiet",
                                     *no_sandbox_args(), *queue_args], env=env)


def runner_on(store, rigs) -> QueueRunner:
    return QueueRunner(store, rigs.links(), "bench-test", say=lambda line: None, twin_pushes=False)


def rig_verdicts(store) -> dict[bytes, dict]:
    """Each job's summary as the runner stored it, by the blob it ran."""
    return {job.payload: store.result(job.id)["summary"] for job in store.jobs() if store.result(job.id)}


def assert_marks_follow_the_rigs(feedback: dict, verdict: dict) -> None:
    """Full marks exactly when the rig's verdict says solved, and that verdict in the feedback."""
    judged = feedback["judged_by_the_rule"]
    assert judged["score"] == (3.0 if verdict["solved"] else 0.0), (judged, verdict)
    assert f"judged on rig {verdict['rig']} through the class's queue" in judged["output"], judged
    assert f"solved: {verdict['held']}/10 held" in judged["output"], (judged, verdict)


@pytest.mark.expensive
def test_each_students_own_blob_is_judged_on_a_virtual_rig_through_the_served_queue(tmp_path):
    folder, out = a_class(tmp_path / "class", ("alice", "bob", "carol")), tmp_path / "grades"
    with served_queue(tmp_path) as queue, VirtualRigs(["r01", "r02"], RIG_SPEED) as rigs, \
            serving(runner_on(queue.store, rigs)):
        graded = grade(folder, out, "--queue-server", queue.url, "--queue-wait-minutes", "10",
                       env={"PENDKIT_QUEUE_TOKEN": INSTRUCTOR_TOKEN})
        jobs, verdicts = queue.store.jobs(), rig_verdicts(queue.store)
    assert graded.exit_code == 0, graded.output
    alice, bob, carol = (deploy_feedback(out, student) for student in ("alice", "bob", "carol"))
    # the student's own bytes went to a rig, as the instructor's jobs; carol's never left the grader
    assert sorted(job.payload for job in jobs) == sorted([alice_blob(), bob_blob()])
    assert {(job.team, job.kind, job.state) for job in jobs} == {("instructor", "blob", "done")}
    assert_marks_follow_the_rigs(alice, verdicts[alice_blob()])
    assert_marks_follow_the_rigs(bob, verdicts[bob_blob()])
    # the blob drives the outcome: the kit's design holds (10/10 on an idle machine; a loaded one makes the
    # virtual rigs' heartbeats late), a swing-up pumping 60% of the energy upright needs never does
    assert verdicts[alice_blob()]["held"] > verdicts[bob_blob()]["held"] == 0
    assert alice["the_device_takes_it"]["score"] == bob["the_device_takes_it"]["score"] == 1.0
    assert carol["judged_by_the_rule"]["score"] == 0.0 == carol["the_device_takes_it"]["score"]
    assert "refused by the device's checks" in carol["judged_by_the_rule"]["output"]
    rows = {row["student"]: row for row in csv.DictReader((out / "grades.csv").open())}
    expected_alice = "4" if verdicts[alice_blob()]["solved"] else "1"
    assert (rows["alice"]["10.deploy"], rows["bob"]["10.deploy"], rows["carol"]["10.deploy"]) == (expected_alice,
                                                                                                  "1", "0")
    written = "".join(path.read_text() for path in out.rglob("*.*")) + graded.output
    assert INSTRUCTOR_TOKEN not in written


@pytest.mark.expensive
def test_grade_files_the_jobs_in_the_queues_database_for_its_runners(tmp_path, queue_url):
    """A runner (on a Pi, say) and the grader share the queue's database: SQLite here, PostgreSQL by URL."""
    store = QueueStore(queue_url)
    store.add_team("instructor", INSTRUCTOR_TOKEN, instructor=True)
    folder, out = a_class(tmp_path / "class", ("alice", "bob")), tmp_path / "grades"
    with VirtualRigs(["r01", "r02"], RIG_SPEED) as rigs, serving(runner_on(store, rigs)):
        graded = grade(folder, out, "--queue-db", queue_url, "--queue-wait-minutes", "10")
    assert graded.exit_code == 0, graded.output
    assert sorted(job.payload for job in store.jobs(team="instructor")) == sorted([alice_blob(), bob_blob()])
    verdicts = rig_verdicts(store)
    assert_marks_follow_the_rigs(deploy_feedback(out, "alice"), verdicts[alice_blob()])
    assert_marks_follow_the_rigs(deploy_feedback(out, "bob"), verdicts[bob_blob()])
    assert verdicts[alice_blob()]["held"] > verdicts[bob_blob()]["held"] == 0
    store.close()


def test_without_a_queue_the_twin_judges_the_blob_and_the_feedback_says_so(tmp_path):
    folder, out = a_class(tmp_path / "class", ("alice", "bob")), tmp_path / "grades"
    graded = grade(folder, out)
    assert graded.exit_code == 0, graded.output
    alice, bob = deploy_feedback(out, "alice"), deploy_feedback(out, "bob")
    assert alice["judged_by_the_rule"]["score"] == 3.0
    assert "judged on the twin's device" in alice["judged_by_the_rule"]["output"]
    assert "no rig queue here" in alice["judged_by_the_rule"]["output"]
    assert bob["judged_by_the_rule"]["score"] == 0.0 and "not solved" in bob["judged_by_the_rule"]["output"]


def test_a_queue_that_cannot_judge_is_refused_before_any_notebook_runs(tmp_path):
    folder, out = a_class(tmp_path / "class", ("alice",)), tmp_path / "grades"
    empty = grade(folder, out, "--queue-db", str(tmp_path / "empty.db"))
    assert empty.exit_code != 0 and "no team 'instructor'" in empty.output and "queue teams" in empty.output
    with served_queue(tmp_path) as queue:
        wrong = grade(folder, out, "--queue-server", queue.url, env={"PENDKIT_QUEUE_TOKEN": "not-the-token"})
        no_token = grade(folder, out, "--queue-server", queue.url, env={"PENDKIT_QUEUE_TOKEN": None})
    assert wrong.exit_code != 0 and "401" in wrong.output and "not-the-token" not in wrong.output
    assert no_token.exit_code != 0 and "PENDKIT_QUEUE_TOKEN" in no_token.output
    assert not out.exists()  # nothing was graded
