"""`pendkit queue` from the command line: the instructor loads the teams from broker-config's credentials
(never printing a token) and looks after the rigs; `serve` runs as a process and logs no token; a team
follows, downloads and cancels its own jobs with its token from the environment or a file, never the
command line."""

import json
import os
import signal
import subprocess
import sys

import pytest
from click.testing import CliRunner

from pendkit.cli import main
from pendkit.link.broker import free_port, wait_for_port, write_classroom_config
from tests.queue.serving import TOKENS, plot_png, run_to_result, served_queue

pytest.importorskip("sqlalchemy")


def invoke(args, **env):
    return CliRunner().invoke(main, ["queue", *args], env={"PENDKIT_QUEUE_TOKEN": None, **env})


def test_teams_come_from_broker_config_and_no_token_is_printed(tmp_path):
    from pendkit.queue.store import QueueStore

    paths = write_classroom_config(["r01", "r02"], tmp_path / "broker")
    logins = {row.split(",")[0]: row.split(",")[1] for row in paths["credentials"].read_text().splitlines()[1:]}
    db = str(tmp_path / "queue.db")
    result = invoke(["teams", "--credentials", str(paths["credentials"]), "--db", db, "--quota-minutes", "20"])
    assert result.exit_code == 0, result.output
    assert "team host-r01" in result.output and "team host-r02" in result.output and "instructor" in result.output
    assert "team r01\n" not in result.output  # a rig's own user is not a team
    for password in logins.values():
        assert password not in result.output
    store = QueueStore(db)
    assert store.team_for_token(logins["host-r02"]) == ("host-r02", False)
    assert store.team_for_token(logins["instructor"]) == ("instructor", True)
    assert store.team_for_token(logins["r01"]) is None
    from pendkit.queue.store import teams

    with store.engine.connect() as db_connection:
        quotas = {row.name: row.quota_rig_s for row in db_connection.execute(teams.select())}
    assert quotas == {"host-r01": 1200.0, "host-r02": 1200.0, "instructor": None}  # 20 rig-minutes a day
    store.close()


def test_rigs_are_listed_and_one_out_of_service_put_back(tmp_path):
    from pendkit.queue.store import QueueStore

    db = str(tmp_path / "queue.db")
    store = QueueStore(db)
    store.register_rig("r01", "bench-1", (150, 450))
    store.register_rig("r02", "bench-1", (150, 450))
    store.take_out("r02", "the pendulum did not settle within 30 s")
    result = invoke(["rigs", "--db", db])
    assert result.exit_code == 0 and "did not settle" in result.output
    assert [line.split()[:2] for line in result.output.splitlines()[:2]] == [["r01", "free"], ["r02", "out"]]
    result = invoke(["rigs", "--db", db, "--put-back", "r02"])
    assert result.exit_code == 0 and "r02 is back in service" in result.output
    assert {row["rig"]: row["state"] for row in store.rigs()} == {"r01": "free", "r02": "free"}
    again = invoke(["rigs", "--db", db, "--put-back", "r02"])
    assert again.exit_code == 2 and "not out of service" in again.output
    store.close()


def test_a_team_follows_downloads_and_cancels_its_own_jobs(tmp_path):
    with served_queue(tmp_path) as queue:
        png = plot_png()
        done = run_to_result(queue.store, "team-a", png=png)
        waiting = queue.store.submit("team-a", "controller", {"controller": "trajopt"})
        theirs = queue.store.submit("team-b", "policy", {"policy": "r-dqn-realistic"})
        as_a = {"PENDKIT_QUEUE_TOKEN": TOKENS["team-a"], "PENDKIT_QUEUE_SERVER": queue.url}

        listed = invoke(["status"], **as_a)
        assert listed.exit_code == 0, listed.output
        assert f"job {done} (controller): done on r01; solved: 9/10 held upright_s=1.84" in listed.output
        assert f"job {waiting} (controller): waiting" in listed.output and f"job {theirs} " not in listed.output

        out = tmp_path / "results"
        fetched = invoke(["result", str(done), "--out", str(out)], **as_a)
        assert fetched.exit_code == 0, fetched.output
        assert (out / f"job-{done}-plot.png").read_bytes() == png
        assert (out / f"job-{done}-telemetry.csv").read_text().startswith("time_s,theta_rad")
        assert json.loads((out / f"job-{done}.json").read_text())["figures"]["held"] == 9
        early = invoke(["result", str(waiting), "--out", str(out)], **as_a)
        assert early.exit_code == 1 and "--wait" in early.output

        token_file = tmp_path / "host-r03.txt"
        token_file.write_text(TOKENS["team-a"] + "\n")
        refused = invoke(["cancel", str(theirs), "--token-file", str(token_file), "--server", queue.url])
        assert refused.exit_code == 1 and f"no job {theirs} of team team-a" in refused.output
        assert queue.store.job(theirs).state == "waiting"
        cancelled = invoke(["cancel", str(waiting), "--token-file", str(token_file), "--server", queue.url])
        assert cancelled.exit_code == 0 and queue.store.job(waiting).state == "cancelled"
        followed = invoke(["status", str(waiting), "--wait"], **as_a)
        assert followed.exit_code == 0 and "cancelled" in followed.output

        for result in (listed, fetched, refused, cancelled, followed):
            assert TOKENS["team-a"] not in result.output


def test_an_excitations_recordings_come_back_for_identification(tmp_path):
    recordings = [{"t_s": [0.0, 0.06], "servo_counts": [300, 340], "angle_rad": [3.14, 3.13]}]
    with served_queue(tmp_path) as queue:
        job_id = run_to_result(queue.store, "team-a", {"excitation": recordings, "recorded_episodes": 1},
                               "episode,t_s\n1,0.0\n")
        result = invoke(["result", str(job_id), "--out", str(tmp_path / "out"), "--server", queue.url],
                        PENDKIT_QUEUE_TOKEN=TOKENS["team-a"])
    assert result.exit_code == 0, result.output
    assert json.loads((tmp_path / "out" / f"job-{job_id}-excitation.json").read_text()) == recordings
    assert f"job {job_id} (controller): done on r01; -" in result.output


def test_a_token_on_the_command_line_is_refused():
    result = invoke(["status", "--token", "abc"])
    assert result.exit_code == 2 and "PENDKIT_QUEUE_TOKEN" in result.output and "abc" not in result.output


def test_serve_runs_as_a_process_and_logs_no_token(tmp_path):
    from pendkit.queue.client import QueueClient, QueueRequestError
    from pendkit.queue.store import QueueStore

    db = tmp_path / "queue.db"
    store = QueueStore(str(db))
    store.add_team("team-a", TOKENS["team-a"])
    job_id = store.submit("team-a", "excitation", {})
    store.close()
    port = free_port()
    server = subprocess.Popen([sys.executable, "-m", "pendkit.cli", "queue", "serve", "--db", str(db), "--port",
                               str(port)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                              env={**os.environ, "PENDKIT_QUEUE_TOKEN": ""})
    try:
        assert wait_for_port("127.0.0.1", port, 60), "the queue did not start"
        client = QueueClient(f"http://127.0.0.1:{port}", token=TOKENS["team-a"])
        assert [job["id"] for job in client.jobs()] == [job_id]
        assert client.state()["jobs"][0] == {"id": job_id, "team": "team-a", "kind": "excitation",
                                             "state": "waiting", "rig": None, "place": 1}
        with pytest.raises(QueueRequestError, match="not a team's") as refused:
            QueueClient(f"http://127.0.0.1:{port}", token="wrong").jobs()
        assert refused.value.status == 401
    finally:
        server.send_signal(signal.SIGTERM)
        out, err = server.communicate(timeout=30)
    assert server.returncode == 0, err
    assert f"queue on http://127.0.0.1:{port}" in out
    assert "GET /api/jobs 200 team=team-a" in err and "GET /api/jobs 401" in err
    assert TOKENS["team-a"] not in out + err and "Traceback" not in err
