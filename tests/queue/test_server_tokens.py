"""The queue's API on a real server: a team sees, fetches and cancels its own jobs only (another team's job
answers exactly as a missing one), an unknown token is 401, a token never comes back in an answer or a log
line, the public state and leaderboard hold no payload or result, and a stored result reaches its team only."""

import json

import pytest

from tests.queue.serving import RESULT, TOKENS, VERDICT, one_line_error, plot_png, run_to_result, served_queue
from tests.system_needs import needs

pytest.importorskip("sqlalchemy")


@pytest.fixture
def queue(tmp_path):
    with served_queue(tmp_path) as served:
        yield served


def test_a_team_never_sees_or_cancels_another_teams_job(queue):
    theirs = queue.store.submit("team-b", "policy", {"policy": "r-dqn-realistic"})
    mine = queue.store.submit("team-a", "controller", {"controller": "energy"})
    status, listed = queue.json("GET", "/api/jobs", "team-a")
    assert status == 200 and [job["id"] for job in listed["jobs"]] == [mine]

    missing = theirs + 100
    for path in ("/api/jobs/{}", "/api/jobs/{}/telemetry.csv", "/api/jobs/{}/plot.png"):
        status_theirs, _, body_theirs = queue.call("GET", path.format(theirs), "team-a")
        status_missing, _, body_missing = queue.call("GET", path.format(missing), "team-a")
        assert status_theirs == status_missing == 404
        assert one_line_error(body_theirs) == one_line_error(body_missing).replace(str(missing), str(theirs))

    status, _, body = queue.call("DELETE", f"/api/jobs/{theirs}", "team-a")
    assert status == 404 and "team-a" in one_line_error(body)
    assert queue.store.job(theirs).state == "waiting"

    status, answer = queue.json("DELETE", f"/api/jobs/{mine}", "team-a")
    assert (status, answer["state"], queue.store.job(mine).state) == (200, "cancelled", "cancelled")
    status, _, body = queue.call("DELETE", f"/api/jobs/{mine}", "team-a")
    assert status == 409 and "cancelled" in one_line_error(body)

    status, answer = queue.json("DELETE", f"/api/jobs/{theirs}", "instructor")  # the instructor cancels any
    assert status == 200 and queue.store.job(theirs).state == "cancelled"


@pytest.mark.parametrize("authorization", [None, "Bearer not-a-token", f"Basic {TOKENS['team-a']}", "Bearer "])
def test_no_or_an_unknown_token_is_401(queue, authorization):
    queue.store.submit("team-a", "controller", {"controller": "energy"})
    headers = {"Authorization": authorization} if authorization is not None else {}
    for method, path in (("GET", "/api/jobs"), ("GET", "/api/jobs/1"), ("DELETE", "/api/jobs/1"),
                         ("GET", "/api/jobs/1/plot.png")):
        status, answer_headers, body = queue.call(method, path, headers=headers)
        assert status == 401 and answer_headers.get("WWW-Authenticate", "").startswith("Bearer"), (method, path)
        one_line_error(body)
    assert queue.store.job(1).state == "waiting"


def test_a_token_is_never_in_an_answer_or_a_log_line(queue):
    job_id = run_to_result(queue.store, "team-a")
    answers = []
    for team in TOKENS:
        for method, path in (("GET", "/api/jobs"), ("GET", f"/api/jobs/{job_id}"), ("GET", "/api/jobs/999"),
                             ("GET", f"/api/jobs/{job_id}/telemetry.csv"), ("DELETE", f"/api/jobs/{job_id}"),
                             ("GET", "/api/state"), ("GET", "/"), ("GET", f"/jobs/{job_id}"), ("GET", "/nowhere"),
                             ("PUT", "/api/jobs")):
            status, headers, body = queue.call(method, path, team)
            answers.append(json.dumps(headers) + body.decode("utf-8", "replace"))
    # a token pasted into a URL by mistake does not reach the log either
    queue.call("GET", f"/api/state?token={TOKENS['team-b']}")
    queue.call("GET", f"/jobs/{TOKENS['team-b']}")
    seen = "\n".join(answers + queue.log)
    assert len(queue.log) >= 30
    for token in TOKENS.values():
        assert token not in seen
    assert any("team=team-a" in line for line in queue.log)  # the log names the team instead


def test_the_public_state_and_leaderboard_hold_no_payload_and_no_result(queue):
    secret_csv = "time_s,theta_rad\n0.0,SECRET-TELEMETRY\n"
    summary = {**RESULT, "note": "SECRET-SUMMARY"}
    done = run_to_result(queue.store, "team-a", summary, secret_csv)
    first = queue.store.submit("team-a", "blob", {"blob": "SECRET-SPEC"}, b"SECRET-PAYLOAD")
    second = queue.store.submit("team-a", "controller", {"controller": "trajopt"})
    other = queue.store.submit("team-b", "policy", {"policy": "r-td3-realistic"})
    queue.store.register_rig("r02", "bench-2", (150, 450))
    queue.store.take_out("r02", "the pendulum did not settle within 30 s")

    status, _, body = queue.call("GET", "/api/state")
    state = json.loads(body)
    assert status == 200
    for secret in ("SECRET", "payload_base64", "summary", "telemetry", "spec"):
        assert secret not in body.decode()
    jobs = {job["id"]: job for job in state["jobs"]}
    assert set(jobs) == {done, first, second, other}
    assert set(jobs[first]) == {"id", "team", "kind", "state", "rig", "place"}
    assert jobs[done]["state"] == "done" and jobs[done]["place"] is None
    # fair share: team-b has used no rig time today, team-a some: team-b first, then team-a in order submitted
    assert [jobs[i]["place"] for i in (other, first, second)] == [1, 2, 3]
    rigs = {rig["rig"]: rig for rig in state["rigs"]}
    assert rigs["r02"]["state"] == "out" and "did not settle" in rigs["r02"]["reason"]
    assert rigs["r01"]["state"] == "free"

    status, _, body = queue.call("GET", "/api/leaderboard")
    assert status == 200 and "SECRET" not in body.decode()
    (entry,) = json.loads(body)["leaderboard"]
    assert entry == {"rank": 1, "team": "team-a", "job_id": done, "verdict": VERDICT, "solved": True,
                     "held": 9, "episodes": 10, "time_to_upright_s": 1.84, "pushes": "7/10 held, not solved"}


def test_the_leaderboard_ranks_each_teams_best_judged_job(queue):
    queue.store.add_team("team-c", "token-of-team-c")

    def judged(held, upright_s, asked=10):
        solved = held >= 9 if asked == 10 else None
        return {"verdict": f"{held}/{asked}", "held": held, "solved": solved, "time_to_upright_s": upright_s,
                "episodes_run": asked, "episodes": []}

    run_to_result(queue.store, "team-a", judged(9, 2.0))
    run_to_result(queue.store, "team-a", judged(6, 1.0))  # worse: its best stays
    run_to_result(queue.store, "team-b", judged(10, 2.5))
    run_to_result(queue.store, "team-b", {"excitation": [], "recorded_episodes": 6})  # no verdict: not ranked
    run_to_result(queue.store, "team-c", judged(9, 1.5))  # as many held as team-a, quicker
    run_to_result(queue.store, "instructor", judged(3, None, asked=4))
    board = queue.json("GET", "/api/leaderboard")[1]["leaderboard"]
    assert [(e["team"], e["verdict"], e["time_to_upright_s"]) for e in board] == [
        ("team-b", "solved: 10/10 held", 2.5), ("team-c", "solved: 9/10 held", 1.5),
        ("team-a", "solved: 9/10 held", 2.0),
        ("instructor", "3/4 held (fewer episodes than the rule's: not judged)", None)]
    assert [e["rank"] for e in board] == [1, 2, 3, 4]


def test_a_stored_result_reaches_its_team_only(queue):
    png = plot_png()
    csv = "time_s,theta_rad\n0.00,3.14\n0.02,3.10\n"
    job_id = run_to_result(queue.store, "team-a", csv=csv, png=png)

    status, job = queue.json("GET", f"/api/jobs/{job_id}", "team-a")
    assert status == 200 and job["state"] == "done" and job["summary"] == RESULT
    assert job["figures"]["verdict"] == VERDICT and job["figures"]["held"] == 9
    assert job["telemetry"] and job["plot"]
    status, headers, body = queue.call("GET", f"/api/jobs/{job_id}/telemetry.csv", "team-a")
    assert status == 200 and body.decode() == csv and headers["Content-Type"].startswith("text/csv")
    assert "attachment" in headers["Content-Disposition"]
    status, headers, body = queue.call("GET", f"/api/jobs/{job_id}/plot.png", "team-a")
    assert status == 200 and body == png and headers["Content-Type"] == "image/png"

    for path in (f"/api/jobs/{job_id}", f"/api/jobs/{job_id}/telemetry.csv", f"/api/jobs/{job_id}/plot.png"):
        status, _, body = queue.call("GET", path, "team-b")
        assert status == 404 and b"3.14" not in body and body[:4] != png[:4]


def test_a_waiting_job_has_no_result_to_download(queue):
    job_id = queue.store.submit("team-a", "controller", {"controller": "energy"})
    status, job = queue.json("GET", f"/api/jobs/{job_id}", "team-a")
    assert (status, job["summary"], job["telemetry"], job["plot"]) == (200, None, False, False)
    status, _, body = queue.call("GET", f"/api/jobs/{job_id}/plot.png", "team-a")
    assert status == 404 and "waiting" in one_line_error(body)


@needs("openssl")
def test_over_https_with_the_classrooms_certificate_a_token_never_crosses_in_clear(tmp_path):
    from pendkit.link.tls import make_classroom_ca
    from pendkit.queue.client import QueueClient, QueueRequestError

    (tmp_path / "broker").mkdir()
    tls = make_classroom_ca(tmp_path / "broker")
    with served_queue(tmp_path, tls=(str(tls["cert"]), str(tls["key"]))) as queue:
        assert queue.url.startswith("https://127.0.0.1:")
        job_id = queue.store.submit("team-a", "controller", {"controller": "energy"})
        client = QueueClient(queue.url, token=TOKENS["team-a"], tls_ca=tls["ca"])
        assert [job["id"] for job in client.jobs()] == [job_id]
        with pytest.raises(QueueRequestError, match="cannot reach the queue"):  # a server it cannot check
            QueueClient(queue.url, token=TOKENS["team-a"]).jobs()
        plain = queue.raw(b"GET /api/jobs HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer "
                          + TOKENS["team-a"].encode() + b"\r\n\r\n")
        assert b"job" not in plain  # plain http to the https port gets nothing back
        assert client.state()["jobs"][0]["id"] == job_id
    assert not any("Traceback" in line for line in queue.log)
