"""The queue's pages in a real browser (Debian's Chromium driven by Playwright, as the demo test does): the
class page lists the rigs and jobs and follows a job as its state changes; a job's result page opens for its
team with the token typed in (never in the URL), showing the verdict, each episode and the plot. Screenshots
go to build/browser-test/."""

import pytest

from tests.browser.test_demo_in_browser import CHROMIUM, CHROMIUM_ARGS, SHOTS
from tests.queue.serving import RESULT, TOKENS, VERDICT, run_to_result, served_queue
from tests.system_needs import skip_unless

WAIT_MS = 30_000  # generous: the page polls every 2 s
OKABE_ITO_ORANGE = "rgb(230, 159, 0)"


@pytest.fixture
def browser_and_queue(tmp_path):
    skip_unless("chromium")
    pytest.importorskip("playwright")
    pytest.importorskip("sqlalchemy")
    from playwright.sync_api import sync_playwright

    SHOTS.mkdir(parents=True, exist_ok=True)
    with served_queue(tmp_path) as queue, sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            yield browser.new_page(viewport={"width": 1200, "height": 1000}), queue
        finally:
            browser.close()


def cell_text(page, row_selector: str, column: int) -> str:
    return page.inner_text(f"{row_selector} td >> nth={column}").strip()


def test_the_class_page_follows_rigs_and_jobs_live(browser_and_queue):
    page, queue = browser_and_queue
    store = queue.store
    store.register_rig("r01", "bench-1", (150, 450))
    store.register_rig("r02", "bench-1", (150, 450))
    store.take_out("r02", "the pendulum did not settle within 30 s")
    first = store.submit("team-a", "controller", {"controller": "energy"})
    second = store.submit("team-b", "policy", {"policy": "r-dqn-realistic"})

    page.goto(queue.url)
    job_row = f'#jobs tr[data-job="{first}"]'
    page.wait_for_selector(job_row, timeout=WAIT_MS)
    assert [cell_text(page, job_row, k) for k in range(5)] == [f"job {first}", "team-a", "controller", "waiting", "1"]
    assert cell_text(page, f'#jobs tr[data-job="{second}"]', 4) == "2"
    assert cell_text(page, '#rigs tr[data-rig="r02"]', 1) == "out"
    assert "did not settle" in cell_text(page, '#rigs tr[data-rig="r02"]', 4)
    assert page.locator("table caption").count() == 3 and page.locator("thead th[scope=col]").count() == 19

    claimed = store.claim("r01", "bench-1")  # a runner takes the first job
    assert claimed.id == first
    page.wait_for_function(f"""() => {{
        const row = document.querySelector('{job_row}');
        return row && row.cells[3].textContent === 'running' && row.cells[5].textContent === 'r01';
    }}""", timeout=WAIT_MS)
    assert cell_text(page, '#rigs tr[data-rig="r01"]', 1) == "busy"
    assert cell_text(page, '#rigs tr[data-rig="r01"]', 2) == f"job {first}"
    badge = page.locator(f"{job_row} .state")
    assert badge.inner_text() == "running"  # the state in words; the colour only repeats it
    assert badge.evaluate("element => getComputedStyle(element).backgroundColor") == OKABE_ITO_ORANGE
    assert "1 busy, 1 out of service" in page.inner_text("#summary")
    page.screenshot(path=str(SHOTS / "queue-class-running.png"), full_page=True)

    store.finish(first, RESULT, "time_s,theta_rad\n0,3.14\n", None)
    page.wait_for_function(f"() => document.querySelector('{job_row}').cells[3].textContent === 'done'",
                           timeout=WAIT_MS)
    page.wait_for_selector('#leaderboard tr[data-team="team-a"]', timeout=WAIT_MS)
    leader = '#leaderboard tr[data-team="team-a"]'
    assert [cell_text(page, leader, k) for k in range(5)] == ["1", "team-a", VERDICT, "9/10", "1.84"]
    page.screenshot(path=str(SHOTS / "queue-class-done.png"), full_page=True)


def test_a_jobs_result_page_opens_for_its_team_with_the_token_typed_in(browser_and_queue):
    page, queue = browser_and_queue
    job_id = run_to_result(queue.store, "team-a")
    page.goto(f"{queue.url}/jobs/{job_id}")

    page.fill("#token", TOKENS["team-b"])  # another team's token: the job is not theirs
    page.click("text=Show the result")
    page.wait_for_selector(f"text=Your team has no job {job_id}.", timeout=WAIT_MS)
    assert page.is_hidden("#result")

    page.fill("#token", TOKENS["team-a"])
    page.click("text=Show the result")
    page.wait_for_selector("#result:not([hidden])", timeout=WAIT_MS)
    page.wait_for_function("() => { const img = document.getElementById('plot');"
                           " return img.complete && img.naturalWidth > 0; }", timeout=WAIT_MS)
    def fact(term: str) -> str:
        return page.inner_text(f"#facts dt:text-is('{term}') + dd").strip()

    assert (fact("Verdict"), fact("Solved"), fact("Episodes held"), fact("Time to upright (s)")) == (
        VERDICT, "yes", "9 of 10", "1.84")
    assert page.locator("#episodes tbody tr").count() == 10
    assert page.inner_text("#episodes tbody tr >> nth=3").split("\t")[1] == "no"  # episode 4 did not hold
    page.wait_for_selector("#csv:not([hidden])", timeout=WAIT_MS)  # fetched after the plot
    link = page.locator("#csv")
    assert link.get_attribute("href").startswith("blob:")
    assert link.get_attribute("download") == f"job-{job_id}-telemetry.csv"
    page.screenshot(path=str(SHOTS / "queue-job-result.png"), full_page=True)

    assert TOKENS["team-a"] not in page.url and page.input_value("#token") == ""
    page.reload()  # kept in this tab's sessionStorage: shown again without typing
    page.wait_for_selector("#result:not([hidden])", timeout=WAIT_MS)
    assert fact("Verdict") == VERDICT
    page.click("text=Forget the token in this tab")
    page.wait_for_selector("#login:not([hidden])", timeout=WAIT_MS)
    assert page.evaluate("() => sessionStorage.length") == 0
    assert all(token not in line for line in queue.log for token in TOKENS.values())
