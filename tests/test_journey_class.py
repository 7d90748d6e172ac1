"""The class's journey, as docs/server.md §1-4 tell it, commands read from the doc's fenced blocks and run one by one
with bash in a fresh virtual environment (tests/journey.py):

1. the teacher installs (``pip install '.[server]'``), creates a login and starts the server;
2. creates the class and the students, whose tokens are printed once;
3. two students run the doc's own command with their tokens: the leaderboard (headless Chromium) shows both,
   verified, under the right names. Then the server goes down; both run again with the doc's config (its
   ``[report.http]`` block appended to the config they run), the results wait in one outbox on one machine; the
   server comes back and each student flushes with the doc's commands: each run is stored exactly once, under its
   own student, with its files, and a student's flush leaves the other's runs waiting;
4. the teacher's official runs: the doc's sweep command with the teacher token -> official rows.

Substituted, and only these: the doc's host ``192.168.0.10`` and ``0.0.0.0`` -> ``127.0.0.1``, its port ``8000``
(also the default of a bare ``robokit serve``) -> a free port, and the token placeholders -> the tokens the doc's
commands printed.
"""

from __future__ import annotations

import os
import re
import signal
import sqlite3
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from journey import ROOT, activated, blocks_under, fresh_checkout, ok, sh, shell_lines, substitute
from server_proc import free_port

CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"
DOC = ROOT / "docs" / "server.md"
PASSWORD = "journey-teacher-pass"
STUDENTS = ("김민준", "이서연")

pytestmark = [pytest.mark.slow, pytest.mark.timeout(3600),
              pytest.mark.skipif(not (os.path.exists(CHROMIUM) and os.path.exists(CHROMEDRIVER)),
                                 reason="needs Debian's chromium and chromium-driver (installed by .ci/run)")]


class Background:
    """A documented ``robokit serve`` line running in the background until :meth:`stop`."""

    def __init__(self, command: str, cwd: Path, env: dict[str, str]) -> None:
        self.proc = subprocess.Popen(["bash", "-c", command], cwd=cwd, env=env, text=True, start_new_session=True,
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        assert self.proc.stdout is not None
        self.lines: list[str] = []
        for line in self.proc.stdout:
            self.lines.append(line)
            if "robokit serve: http://" in line:
                return
        raise AssertionError(f"`{command}` exited before listening:\n" + "".join(self.lines))

    def stop(self) -> None:
        os.killpg(self.proc.pid, signal.SIGTERM)  # bash and the robokit serve it started (their own group)
        assert self.proc.stdout is not None
        self.lines += self.proc.stdout.readlines()
        self.proc.wait(60)


class Journey:
    """The doc's commands, run in order in one checkout (state shared by the steps of the test)."""

    def __init__(self, tmp: Path) -> None:
        self.repo, plain = fresh_checkout(tmp, extras=("server",))
        self.plain = {**plain, "ROBOKIT_TEACHER_PASSWORD": PASSWORD}
        self.env = activated(self.repo, self.plain)
        self.port = free_port()
        self.subs = {"192.168.0.10": "127.0.0.1", "0.0.0.0": "127.0.0.1", "8000": str(self.port)}
        self.server: Background | None = None
        self.tokens: dict[str, str] = {}

    def run(self, line: str, env: dict[str, str] | None = None) -> str:
        line = substitute(line, self.subs)
        if re.match(r"(\S+=\S+ )*robokit serve( |$)", line) and "--create-teacher" not in line:
            self.start(line)
            return ""
        return ok(sh(line, self.repo, env or self.env), line)

    def start(self, line: str) -> None:
        line = line.split(" #")[0].rstrip()  # the comment, as bash would drop it
        if "--port" not in line:  # a bare `robokit serve`: its documented default port is the placeholder
            line += f" --port {self.port}"
        self.stop()
        self.server = Background(line, self.repo, self.env)

    def stop(self) -> None:
        if self.server is not None:
            self.server.stop()
            self.server = None

    def as_student(self, name: str, block: str) -> str:
        """A student pastes a whole block into their shell (so its ``export`` holds for the lines after it)."""
        token = {"rks_7N0pD1b0l3m3Q…": self.tokens[name], "rkt_…": self.tokens.get("official", "")}
        script = "set -e\n" + "\n".join(substitute(line, {**self.subs, **token}) for line in shell_lines(block))
        return ok(sh(script, self.repo, self.env), f"{name}: {block}")

    def runs(self) -> set[str]:
        folder = self.repo / "results"
        return {p.name for p in folder.iterdir()} if folder.is_dir() else set()

    def rows(self) -> list[dict[str, Any]]:
        with sqlite3.connect(self.repo / "robokit-server" / "db.sqlite3") as db:
            db.row_factory = sqlite3.Row
            found = db.execute("SELECT r.run_id, r.student_name, r.verified, r.official, "
                               "(SELECT COUNT(*) FROM course_artifact a WHERE a.result_id = r.id) AS files, "
                               "(SELECT GROUP_CONCAT(a.name) FROM course_artifact a WHERE a.result_id = r.id) AS names "
                               "FROM course_result r").fetchall()
        return [dict(r) for r in found]


@pytest.fixture
def journey(tmp_path: Path) -> Iterator[Journey]:
    j = Journey(tmp_path)
    yield j
    j.stop()


def test_the_class_journey_as_docs_server_md_tells_it(journey: Journey, tmp_path: Path) -> None:
    """One test, its steps in the doc's order (a random test order must not split a journey)."""
    teacher_installs_starts_and_makes_a_class(journey)
    two_students_runs_are_verified_under_their_names(journey, tmp_path)
    a_run_without_the_token_is_refused_loudly_and_retry_delivers_it(journey)
    offline_runs_are_flushed_each_by_its_owner_once_with_files(journey)
    the_teachers_sweep_makes_official_rows(journey)
    assert journey.server is not None
    log = "".join(journey.server.lines)
    assert not any(token in log for token in journey.tokens.values())  # never a token in the server's log


def _leaderboard(url: str, tmp: Path) -> dict[str, list[str]]:
    """The teacher's leaderboard of 1반 / A in headless Chromium: names per table (students, official ...)."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support import expected_conditions as ec
    from selenium.webdriver.support.ui import WebDriverWait

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                f"--user-data-dir={tmp / 'chrome'}"):
        options.add_argument(arg)
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    try:
        wait = WebDriverWait(driver, 60)
        driver.get(f"{url}/accounts/login/")
        driver.find_element(By.NAME, "username").send_keys("teacher")
        driver.find_element(By.NAME, "password").send_keys(PASSWORD)
        driver.find_element(By.CSS_SELECTOR, "button[type=submit]").click()
        wait.until(ec.presence_of_element_located((By.LINK_TEXT, "1반"))).click()
        wait.until(ec.presence_of_element_located((By.LINK_TEXT, "A"))).click()
        wait.until(ec.presence_of_element_located((By.CSS_SELECTOR, "section table.board")))
        return {s.get_attribute("id"): [td.text for td in s.find_elements(By.CSS_SELECTOR, "td.student")]
                for s in driver.find_elements(By.CSS_SELECTOR, "section")}
    finally:
        driver.quit()


def teacher_installs_starts_and_makes_a_class(journey: Journey) -> None:
    install, classroom = blocks_under(DOC, "1. Install and start")
    lines = shell_lines(install)
    assert lines[0].startswith("python3 -m venv .venv") and "pip install '.[server]'" in lines[1]
    ok(sh(lines[0], journey.repo, journey.plain), lines[0])  # the venv line activates: the later lines run in it
    for line in lines[1:]:
        journey.run(line)
    assert journey.server is not None and f"127.0.0.1:{journey.port}" in "".join(journey.server.lines)
    [serve] = shell_lines(classroom)
    journey.run(serve)  # the classroom server replaces the first one
    [make] = blocks_under(DOC, "2. A class, its students")
    printed = "".join(journey.run(line) for line in shell_lines(make))
    journey.tokens = dict(line.split("\t") for line in printed.splitlines() if "\t" in line)
    assert set(journey.tokens) == {"김민준", "이서연", "박지호"}


def two_students_runs_are_verified_under_their_names(journey: Journey, tmp_path: Path) -> None:
    block = blocks_under(DOC, "3. Point students at it")[0]
    made = {}
    for name in STUDENTS:
        before = journey.runs()
        out = journey.as_student(name, block)
        assert "(HTTP 201)" in out, out
        [made[name]] = journey.runs() - before
    rows = {r["run_id"]: r for r in journey.rows()}
    assert {rid: (rows[rid]["student_name"], rows[rid]["verified"]) for rid in made.values()} == {
        made[n]: (n, 1) for n in STUDENTS}
    assert journey.server is not None
    board = _leaderboard(f"http://127.0.0.1:{journey.port}", tmp_path)
    assert sorted(board["students"]) == sorted(STUDENTS) and "unverified" not in board


def a_run_without_the_token_is_refused_loudly_and_retry_delivers_it(journey: Journey) -> None:
    run_block, outbox_block = blocks_under(DOC, "3. Point students at it")
    export, *rest = shell_lines(run_block)
    assert export.startswith("export ROBOKIT_TOKEN=")
    [command] = rest
    before = journey.runs()
    proc = sh(substitute(command, journey.subs), journey.repo, journey.env)  # the student forgot the export
    assert proc.returncode == 5, proc.stdout + proc.stderr  # the documented code
    [line] = [x for x in proc.stderr.splitlines() if x.startswith("robokit: error:")]
    assert "export ROBOKIT_TOKEN=" in line and "robokit outbox retry" in line
    [rid] = journey.runs() - before
    assert (journey.repo / "results" / rid / "result.json").exists()
    assert rid not in {r["run_id"] for r in journey.rows()}
    out = journey.as_student("박지호", "\n".join([export, outbox_block]))
    assert f"{rid}: delivered" in out, out
    row = next(r for r in journey.rows() if r["run_id"] == rid)
    assert (row["student_name"], row["verified"]) == ("박지호", 1)


def offline_runs_are_flushed_each_by_its_owner_once_with_files(journey: Journey) -> None:
    run_block, outbox_block = blocks_under(DOC, "3. Point students at it")
    [config] = blocks_under(DOC, "3. Point students at it", "toml")
    target = journey.repo / "configs" / "sort_robot.toml"  # the student names the variable in their config
    target.write_text(target.read_text(encoding="utf-8") + "\n" + substitute(config, journey.subs) + "\n",
                      encoding="utf-8")
    journey.stop()
    offline = {}
    for name in STUDENTS:
        before = journey.runs()
        out = journey.as_student(name, run_block)
        assert "not delivered" in out and "kept in the outbox" in out, out
        [offline[name]] = journey.runs() - before
    [serve] = shell_lines(blocks_under(DOC, "1. Install and start")[1])
    journey.run(serve)

    kim, lee = STUDENTS
    export = shell_lines(run_block)[0]  # "with their token set": the same shell as their run
    first = journey.as_student(kim, "\n".join([export, outbox_block]))
    assert f"{offline[kim]}: delivered" in first and "artifacts: " in first, first
    assert "left waiting, not yours: 1 made under token sha256:" in first
    rows = {r["run_id"]: r for r in journey.rows()}
    assert offline[kim] in rows and offline[lee] not in rows  # nothing stored under the wrong name
    second = journey.as_student(lee, "\n".join([export, outbox_block]))
    assert f"{offline[lee]}: delivered" in second and "left waiting" not in second

    rows_list = journey.rows()
    assert len(rows_list) == len({r["run_id"] for r in rows_list})  # each run once
    rows = {r["run_id"]: r for r in rows_list}
    for name in STUDENTS:
        row = rows[offline[name]]
        assert (row["student_name"], row["verified"], row["official"]) == (name, 1, 0)
        assert {"trace.jsonl", "config.toml"} <= set(row["names"].split(",")), row  # with its files


def the_teachers_sweep_makes_official_rows(journey: Journey) -> None:
    line = next(cell for cell in re.findall(r"`(robokit manage teacher_token [^`]+)`", DOC.read_text("utf-8")))
    kind, token = journey.run(line).strip().split("\t")
    assert kind == "official"
    journey.tokens["official"] = token
    [sweep] = [b for b in blocks_under(DOC, "4. What the teacher sees") if "robokit sweep" in b]
    seeds = re.search(r"--seeds (\d+):(\d+)", sweep)
    assert seeds is not None
    before = {r["run_id"] for r in journey.rows()}
    journey.as_student("김민준", sweep)  # the teacher's shell: only the rkt_ placeholder is used
    new = [r for r in journey.rows() if r["run_id"] not in before]
    assert len(new) == int(seeds.group(2)) - int(seeds.group(1))
    assert {(r["student_name"], r["verified"], r["official"]) for r in new} == {("김민준", 1, 1)}
