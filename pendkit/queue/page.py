"""The class page and a job's result page: HTML, one script and one style sheet, served from memory by
`server.py` (no file is read from disk).

Accessible as a matter of course: semantic tables with captions and header cells, every state written as a
word (its colour only repeats it, from the Okabe-Ito palette, which colour-blind readers can tell apart), a
summary line announced when it changes, forms with labels. The script sets text only (`textContent`), never
HTML, so a team's name or a job's reason cannot inject markup. The token is typed into a password field and
kept, if asked, in the tab's `sessionStorage`; it goes to the server in a header, never in a URL.
"""

from __future__ import annotations

_HEAD = """<!doctype html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{title}</title>
<link rel="stylesheet" href="/assets/queue.css">
<script src="/assets/queue.js" defer></script>
</head>
"""

_CLASS_TABLES = (  # (id, heading, caption, column headers); the script fills the bodies
    ("rigs", "Rigs", "Every rig: free, busy with a job, or out of service with the reason",
     ("Rig", "State", "Job", "Servo range (counts)", "Reason", "Last heard (s ago)")),
    ("jobs", "Jobs", "Waiting and running jobs, and the latest finished ones; place: the order fair share takes them",
     ("Job", "Team", "Kind", "State", "Place in queue", "Rig")),
    ("leaderboard", "Leaderboard",
     "Each team's best judged job on a rig: solved first, then episodes held, then the quicker swing-up",
     ("Rank", "Team", "Best verdict", "Episodes held", "Time to upright (s)", "Twin with pushes", "Job")),
)


def _table_section(table_id: str, heading: str, caption: str, columns: tuple[str, ...]) -> str:
    """A section of the class page: its heading and a table with a caption and column headers."""
    headers = "".join(f'<th scope="col">{column}</th>' for column in columns)
    return (f'<section aria-labelledby="{table_id}-title">\n<h2 id="{table_id}-title">{heading}</h2>\n'
            f'<table id="{table_id}">\n<caption>{caption}</caption>\n<thead><tr>{headers}</tr></thead>\n'
            '<tbody></tbody>\n</table>\n</section>\n')


CLASS_PAGE = _HEAD.format(title="pendkit queue: the class's rigs and jobs") + """<body data-page="class">
<header>
<h1>The class's rigs and jobs</h1>
<p id="summary" role="status" aria-live="polite">Loading the queue&hellip;</p>
<p id="updated" class="quiet">Updates every 2 s.</p>
</header>
<main>
""" + "".join(_table_section(*table) for table in _CLASS_TABLES) + """<section aria-labelledby="find-title">
<h2 id="find-title">Your job's result</h2>
<form id="find-job" method="post">
<label for="job-id">Job number</label>
<input id="job-id" name="job" inputmode="numeric" pattern="[0-9]+" required autocomplete="off">
<button type="submit">Open its result page</button>
</form>
</section>
</main>
</body>
</html>
"""


def job_page(job_id: int) -> str:
    """A job's result page; the script asks the team's token and fetches the job with it."""
    return _HEAD.format(title=f"pendkit queue: job {job_id}") + f"""<body data-page="job" data-job="{job_id}">
<header>
<h1>Job {job_id}</h1>
<p><a href="/">Back to the class page</a></p>
</header>
<main>
<section id="login" aria-labelledby="login-title">
<h2 id="login-title">Your team's token</h2>
<form id="token-form" method="post">
<label for="token">Team token (the line in your team's login file)</label>
<input id="token" name="token" type="password" autocomplete="off" required>
<p><input id="remember" type="checkbox" checked>
<label for="remember">Keep it in this tab until the tab closes</label></p>
<button type="submit">Show the result</button>
</form>
</section>
<p id="message" role="alert"></p>
<section id="result" aria-labelledby="result-title" hidden>
<h2 id="result-title">Result</h2>
<dl id="facts"></dl>
<table id="episodes">
<caption>Each episode on the rig, from rest after the rig reset</caption>
<thead><tr></tr></thead>
<tbody></tbody>
</table>
<figure id="plot-figure" hidden>
<img id="plot" alt="The job's telemetry plotted over time (the CSV below holds the same numbers)">
<figcaption>The telemetry over time</figcaption>
</figure>
<p><a id="csv" download="job-{job_id}-telemetry.csv" hidden>Download the telemetry (CSV)</a></p>
<p><button id="forget" type="button">Forget the token in this tab</button></p>
</section>
</main>
</body>
</html>
"""


_CSS = """
:root { --orange: #E69F00; --sky: #56B4E9; --green: #009E73; --yellow: #F0E442; --blue: #0072B2;
        --vermillion: #D55E00; --purple: #CC79A7; --ink: #1a1a1a; }
body { font-family: system-ui, sans-serif; color: var(--ink); background: #fff; margin: 1.5rem; line-height: 1.4; }
h1 { font-size: 1.6rem; margin: 0 0 .3rem; }
h2 { font-size: 1.25rem; margin: 1.5rem 0 .5rem; }
.quiet { color: #555; font-size: .9rem; margin: 0; }
table { border-collapse: collapse; min-width: 40rem; }
caption { text-align: left; color: #444; padding: .2rem 0 .4rem; }
th, td { border: 1px solid #999; padding: .3rem .6rem; text-align: left; vertical-align: top; }
thead th { background: #eee; }
td.empty { color: #555; font-style: italic; }
.state { display: inline-block; padding: 0 .5rem; border-radius: .3rem; border: 1px solid var(--ink);
         color: #000; font-weight: 600; }
.state-free, .state-done, .state-solved { background: var(--green); }
.state-busy, .state-running { background: var(--orange); }
.state-waiting { background: var(--sky); }
.state-out, .state-failed, .state-unsolved { background: var(--vermillion); }
.state-cancelled { background: var(--purple); }
a:focus, button:focus, input:focus { outline: 3px solid var(--blue); outline-offset: 2px; }
dl { display: grid; grid-template-columns: max-content auto; gap: .2rem 1rem; }
dt { font-weight: 600; }
dd { margin: 0; }
#message:empty { display: none; }
#message { border-left: .4rem solid var(--vermillion); padding: .3rem .6rem; background: #fff4ec; }
img#plot { max-width: 100%; border: 1px solid #999; }
"""

_JS = r"""
"use strict";

function cell(text) {
  const td = document.createElement("td");
  td.textContent = text === null || text === undefined || text === "" ? "\u2014" : String(text);
  return td;
}

function stateCell(state) {
  const td = document.createElement("td");
  const badge = document.createElement("span");
  badge.className = "state state-" + state;
  badge.textContent = state;
  td.append(badge);
  return td;
}

function jobLink(jobId) {
  const td = document.createElement("td");
  if (jobId === null || jobId === undefined) { td.textContent = "\u2014"; return td; }
  const link = document.createElement("a");
  link.href = "/jobs/" + Number(jobId);
  link.textContent = "job " + Number(jobId);
  td.append(link);
  return td;
}

function fill(table, rows, emptyText) {
  const body = table.tBodies[0];
  const columns = table.tHead.rows[0].cells.length || 1;
  body.replaceChildren(...rows);
  if (!rows.length) {
    const row = document.createElement("tr");
    const td = cell(emptyText);
    td.colSpan = columns;
    td.className = "empty";
    row.append(td);
    body.append(row);
  }
}

function seconds(value) {
  return typeof value === "number" ? value.toFixed(2) : null;
}

async function getJSON(url, token) {
  const headers = token ? { Authorization: "Bearer " + token } : {};
  const response = await fetch(url, { headers, cache: "no-store" });
  let body = null;
  try { body = await response.json(); } catch (error) { body = null; }
  if (!response.ok) {
    const problem = new Error(body && body.error ? body.error : "the server answered " + response.status);
    problem.status = response.status;
    throw problem;
  }
  return body;
}

// --- the class page ---
function renderState(state) {
  fill(document.getElementById("rigs"), state.rigs.map((rig) => {
    const row = document.createElement("tr");
    row.dataset.rig = rig.rig;
    row.append(cell(rig.rig), stateCell(rig.state), jobLink(rig.job_id),
               cell(rig.servo_range ? rig.servo_range.join("\u2013") : null), cell(rig.reason), cell(rig.seen_s_ago));
    return row;
  }), "No rig has reported yet: start a runner (pendkit queue run).");
  fill(document.getElementById("jobs"), state.jobs.map((job) => {
    const row = document.createElement("tr");
    row.dataset.job = job.id;
    row.append(jobLink(job.id), cell(job.team), cell(job.kind), stateCell(job.state),
               cell(job.state === "waiting" ? job.place : null), cell(job.rig));
    return row;
  }), "No jobs yet.");
  const count = (items, state) => items.filter((item) => item.state === state).length;
  document.getElementById("summary").textContent =
    `Rigs: ${count(state.rigs, "free")} free, ${count(state.rigs, "busy")} busy, ${count(state.rigs, "out")} out ` +
    `of service. Jobs: ${count(state.jobs, "waiting")} waiting, ${count(state.jobs, "running")} running.`;
}

function renderLeaderboard(board) {
  fill(document.getElementById("leaderboard"), board.leaderboard.map((entry) => {
    const row = document.createElement("tr");
    row.dataset.team = entry.team;
    row.append(cell(entry.rank), cell(entry.team), cell(entry.verdict), cell(`${entry.held}/${entry.episodes}`),
               cell(seconds(entry.time_to_upright_s)), cell(entry.pushes), jobLink(entry.job_id));
    return row;
  }), "No judged job has finished yet.");
}

let finishedSeen = null;

async function refreshBoard() {
  try { renderLeaderboard(await getJSON("/api/leaderboard")); } catch (error) { /* the state line says why */ }
}

async function pollClass() {
  const updated = document.getElementById("updated");
  try {
    const state = await getJSON("/api/state");
    renderState(state);
    updated.textContent = "Updated at " + new Date().toLocaleTimeString() + "; updates every 2 s.";
    const finished = state.jobs.filter((job) => job.state === "done").map((job) => job.id).join(",");
    if (finished !== finishedSeen) {  // a job finished: the leaderboard may have changed
      finishedSeen = finished;
      refreshBoard();
    }
  } catch (error) {
    updated.textContent = "Cannot reach the queue (" + error.message + "); trying again.";
  }
  setTimeout(pollClass, 2000);
}

function classPage() {
  document.getElementById("find-job").addEventListener("submit", (event) => {
    event.preventDefault();
    const jobId = document.getElementById("job-id").value.trim();
    if (/^[0-9]+$/.test(jobId)) window.location.assign("/jobs/" + jobId);
  });
  pollClass();
}

// --- a job's page ---
const TOKEN_KEY = "pendkit-queue-token";

function fact(list, term, value) {
  const dt = document.createElement("dt");
  dt.textContent = term;
  const dd = document.createElement("dd");
  if (value instanceof Node) dd.append(value);
  else dd.textContent = value === null || value === undefined ? "\u2014" : String(value);
  list.append(dt, dd);
}

function shown(value) {
  if (value === true) return "yes";
  if (value === false) return "no";
  if (typeof value === "number") return Number.isInteger(value) ? String(value) : value.toFixed(2);
  if (value === null || value === undefined) return null;
  if (Array.isArray(value)) return value.length ? value.map(String).join(", ") : "none";
  return typeof value === "object" ? JSON.stringify(value) : String(value);
}

function renderEpisodes(episodes) {
  const table = document.getElementById("episodes");
  const rows = Array.isArray(episodes) ? episodes.filter((e) => e && typeof e === "object") : [];
  const keys = [];
  rows.forEach((episode) => Object.keys(episode).forEach((key) => { if (!keys.includes(key)) keys.push(key); }));
  const head = table.tHead.rows[0];
  head.replaceChildren(...["episode", ...keys].map((key) => {
    const th = document.createElement("th");
    th.scope = "col";
    th.textContent = key.replace(/_s$/, " (s)").replace(/_rad$/, " (rad)").replaceAll("_", " ");
    return th;
  }));
  fill(table, rows.map((episode, index) => {
    const row = document.createElement("tr");
    row.append(cell(index + 1), ...keys.map((key) => cell(shown(episode[key]))));
    return row;
  }), "No episodes (yet).");
}

async function fetchBlob(url, token) {
  const response = await fetch(url, { headers: { Authorization: "Bearer " + token }, cache: "no-store" });
  if (!response.ok) throw new Error("the server answered " + response.status);
  return URL.createObjectURL(await response.blob());
}

function renderJob(job) {
  const facts = document.getElementById("facts");
  facts.replaceChildren();
  const state = document.createElement("span");
  state.className = "state state-" + job.state;
  state.textContent = job.state;
  fact(facts, "State", state);
  fact(facts, "Team", job.team);
  fact(facts, "Kind", job.kind);
  fact(facts, "Rig", job.rig);
  const figures = job.figures;
  if (figures) {
    const verdict = document.createElement("span");
    verdict.className = "state state-" + (figures.solved ? "solved" : "unsolved");
    verdict.textContent = figures.verdict;
    fact(facts, "Verdict", verdict);
    fact(facts, "Solved", figures.solved ? "yes" : "no");
    fact(facts, "Episodes held", `${figures.held} of ${figures.episodes}`);
    fact(facts, "Time to upright (s)", seconds(figures.time_to_upright_s) || "none held");
    if (figures.pushes) fact(facts, "Twin with pushes", figures.pushes);
  } else if (job.summary && "recorded_episodes" in job.summary) {
    fact(facts, "Recorded episodes", job.summary.recorded_episodes);
  }
  if (job.summary && job.summary.stopped) fact(facts, "Stopped", job.summary.stopped);
  fact(facts, "Rig time (s)", job.rig_s);
  if (job.reason) fact(facts, "Reason", job.reason);
  renderEpisodes(job.summary ? job.summary.episodes : []);
}

async function showJob(token) {
  const jobId = document.body.dataset.job;
  const message = document.getElementById("message");
  let job;
  try {
    job = await getJSON("/api/jobs/" + jobId, token);
  } catch (error) {
    message.textContent = error.status === 401 ? "That token is not a team's: " + error.message
      : error.status === 404 ? "Your team has no job " + jobId + "." : "Cannot load the job: " + error.message;
    if (error.status === 401) sessionStorage.removeItem(TOKEN_KEY);
    if (!error.status) setTimeout(() => showJob(token), 2000);
    return;
  }
  message.textContent = "";
  document.getElementById("login").hidden = true;
  document.getElementById("result").hidden = false;
  renderJob(job);
  const plot = document.getElementById("plot");
  if (job.plot && !plot.src) {
    plot.src = await fetchBlob(`/api/jobs/${jobId}/plot.png`, token);
    document.getElementById("plot-figure").hidden = false;
  }
  const csv = document.getElementById("csv");
  if (job.telemetry && !csv.href) {
    csv.href = await fetchBlob(`/api/jobs/${jobId}/telemetry.csv`, token);
    csv.hidden = false;
  }
  if (job.state === "waiting" || job.state === "running") setTimeout(() => showJob(token), 2000);
}

function jobPage() {
  const form = document.getElementById("token-form");
  form.addEventListener("submit", (event) => {
    event.preventDefault();
    const token = document.getElementById("token").value.trim();
    if (!token) return;
    if (document.getElementById("remember").checked) sessionStorage.setItem(TOKEN_KEY, token);
    document.getElementById("token").value = "";
    showJob(token);
  });
  document.getElementById("forget").addEventListener("click", () => {
    sessionStorage.removeItem(TOKEN_KEY);
    window.location.reload();
  });
  const kept = sessionStorage.getItem(TOKEN_KEY);
  if (kept) showJob(kept);
}

document.addEventListener("DOMContentLoaded", () => {
  if (document.body.dataset.page === "class") classPage(); else jobPage();
});
"""

ASSETS = {
    "/assets/queue.css": (_CSS, "text/css; charset=utf-8"),
    "/assets/queue.js": (_JS, "text/javascript; charset=utf-8"),
}
