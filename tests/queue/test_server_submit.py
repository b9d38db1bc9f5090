"""Submitting jobs through the server: as JSON or multipart, from the client and the command line, each checked by
`make_job` (the device's own checks for a blob) before anything is stored; the instructor alone sets a priority."""

import base64
import dataclasses
import json

import pytest
from click.testing import CliRunner

from pendkit.cli import main
from tests.queue.serving import TOKENS, one_line_error, served_queue

pytest.importorskip("sqlalchemy")


@pytest.fixture
def queue(tmp_path):
    with served_queue(tmp_path) as served:
        yield served


@pytest.fixture(scope="module")
def blobs():
    """The energy swing-up packed for the kit's servo, and for one that turns less far."""
    from pendkit.deploy.swingup_design import design_swing_up
    from pendkit.device.controller_blob import pack
    from pendkit.rig import RigParams

    kit = RigParams()
    narrow = dataclasses.replace(kit, servo_range_deg=60.0)
    return pack(design_swing_up(kit, "energy")), pack(design_swing_up(narrow, "energy"))


def multipart(fields: dict, payload: bytes | None, boundary: str = "pendkit-boundary") -> tuple[bytes, dict]:
    parts = [f'--{boundary}\r\nContent-Disposition: form-data; name="{name}"\r\n\r\n{value}\r\n'.encode()
             for name, value in fields.items()]
    if payload is not None:
        parts.append(f'--{boundary}\r\nContent-Disposition: form-data; name="payload"; filename="x.pkcb"\r\n'
                     "Content-Type: application/octet-stream\r\n\r\n".encode() + payload + b"\r\n")
    body = b"".join(parts) + f"--{boundary}--\r\n".encode()
    return body, {"Content-Type": f"multipart/form-data; boundary={boundary}"}


def test_a_controller_job_as_json_is_queued_for_its_team(queue):
    status, headers, body = queue.call("POST", "/api/jobs", "team-a", json.dumps(
        {"kind": "controller", "options": {"controller": "energy", "preset": "turnigy-tgy-wp23", "episodes": 3}}
    ).encode(), {"Content-Type": "application/json"})
    answer = json.loads(body)
    assert status == 201 and headers["Location"] == f"/api/jobs/{answer['id']}" and answer["state"] == "waiting"
    job = queue.store.job(answer["id"], "team-a")
    assert job.kind == "controller" and job.spec["episodes"] == 3 and job.servo_range == (200, 400)
    assert job.time_limit_s == job.spec["time_limit_s"] and job.payload  # the designed blob goes to the rig
    assert queue.store.job(answer["id"], "team-b") is None


def test_a_blob_goes_through_the_devices_checks_before_it_is_stored(queue, blobs):
    kit_blob, narrow_blob = blobs
    body, headers = multipart({"kind": "blob", "options": "{}"}, kit_blob)
    status, _, answer = queue.call("POST", "/api/jobs", "team-a", body, headers)
    assert status == 201, answer
    assert queue.store.job(json.loads(answer)["id"]).payload == kit_blob

    for payload, says in ((narrow_blob, "designed for a servo"), (kit_blob[:-3], "device's checks"),
                          (b"\x89PNG not a blob", "device's checks"), (None, "needs the blob's bytes")):
        body, headers = multipart({"kind": "blob"}, payload)
        status, _, answer = queue.call("POST", "/api/jobs", "team-a", body, headers)
        assert status == 400 and says in one_line_error(answer), answer
    assert len(queue.store.jobs()) == 1


def test_the_instructor_alone_sets_a_priority(queue):
    request = {"kind": "excitation", "options": {"episodes": 1}, "priority": 5}
    status, answer = queue.json("POST", "/api/jobs", "team-a", request)
    assert status == 403 and "only the instructor" in answer["error"]
    status, answer = queue.json("POST", "/api/jobs", "instructor", request)
    assert status == 201
    queue.store.submit("team-a", "controller", {"controller": "energy"})  # earlier in the queue's order ...
    queue.store.register_rig("r01", "bench-1", None)
    assert queue.store.claim("r01", "bench-1").id == answer["id"]  # ... but the instructor's goes first


def test_a_team_submits_from_the_command_line_and_a_notebook(queue, blobs, tmp_path):
    from pendkit.queue.client import QueueClient

    blob_file = tmp_path / "swingup.pkcb"
    blob_file.write_bytes(blobs[0])
    environment = {"PENDKIT_QUEUE_TOKEN": TOKENS["team-b"], "PENDKIT_QUEUE_SERVER": queue.url}
    result = CliRunner().invoke(main, ["queue", "submit", "--blob", str(blob_file)], env=environment)
    assert result.exit_code == 0, result.output
    job_id = int(result.output.split()[1])
    assert f"pendkit queue status {job_id} --wait" in result.output and f"{queue.url}/jobs/{job_id}" in result.output
    assert queue.store.job(job_id, "team-b").payload == blobs[0]

    refused = CliRunner().invoke(main, ["queue", "submit", "--policy", "no-such-policy"], env=environment)
    assert refused.exit_code == 1 and "unknown policy" in refused.output.splitlines()[-1]

    notebook = QueueClient(queue.url, token=TOKENS["team-b"])
    excitation = notebook.submit_excitation(time_limit_s=120)
    assert queue.store.job(excitation).time_limit_s == 120
    assert [job["id"] for job in notebook.jobs()] == [job_id, excitation]
    assert TOKENS["team-b"] not in repr(notebook)


def test_a_base64_payload_is_the_same_as_a_file(queue, blobs):
    request = {"kind": "blob", "payload_base64": base64.b64encode(blobs[0]).decode()}
    status, answer = queue.json("POST", "/api/jobs", "team-a", request)
    assert status == 201 and queue.store.job(answer["id"]).payload == blobs[0]
