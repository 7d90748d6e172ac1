"""The outbox under bad input: entries that can never be delivered, entries for a server that is down, broken
entry files, folders that are not there, filesystem errors, and lock files that must not pile up.

Real files and a real HTTP server on 127.0.0.1 (``report_server``); entries are written with ``Outbox.put`` as
the http reporter writes them, then ``robokit outbox flush`` runs in-process through ``robokit.cli.main``.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from report_server import Answer, CourseServer, closed_port_url, make_payload
from robokit_plugins.http_report import HttpSender

from robokit.cli import main
from robokit.report.outbox import Outbox

FAST = {"retries": 0, "connect_timeout": 2.0, "read_timeout": 5.0}


def put(box: Outbox, i: int, url: str, created_at: float) -> str:
    entry = box.put(make_payload(i), url, FAST)
    entry.data["created_at"] = created_at  # the order of the queue: oldest first
    entry.path.write_text(json.dumps(entry.data))
    return entry.run_id


@pytest.fixture
def server():
    srv = CourseServer().start()
    yield srv
    srv.stop()


def test_an_entry_that_can_never_be_delivered_moves_to_failed_and_blocks_nothing(tmp_path: Path, server,
                                                                                  capsys) -> None:
    """Oldest first: a malformed URL (written by an older robokit that did not check URLs), then a good entry, then
    one the server refuses (422), then another good one. Both good ones are delivered; both bad ones are in
    failed/ with why."""
    box = Outbox(tmp_path / "outbox")
    bad_url = put(box, 1, "http://course.example.org:99999/api/", 1.0)
    good_1 = put(box, 2, server.url, 2.0)
    refused = put(box, 3, server.url, 3.0)
    good_2 = put(box, 4, server.url, 4.0)
    server.plan = lambda n: Answer(422, '{"error": "bad field"}', store=False) if n == 1 else Answer()
    assert main(["outbox", "flush", "--dir", str(box.root)]) == 1  # something was refused
    out = capsys.readouterr().out
    assert sorted(server.stored) == sorted([good_1, good_2])
    assert server.keys() == [good_1, refused, good_2]  # the malformed one was never sent
    assert {e.run_id for e in box.failed()} == {bad_url, refused}
    assert not box.entries()
    failed = {e.run_id: e.last_error for e in box.failed()}
    assert "malformed URL" in failed[bad_url] and "Port out of range" in failed[bad_url]
    assert failed[refused].startswith("HTTP 422")
    assert "2 delivered, 2 refused (moved to failed/), 0 still waiting" in out


def test_a_server_that_is_down_does_not_block_entries_for_another(tmp_path: Path, server, capsys) -> None:
    box = Outbox(tmp_path / "outbox")
    down = closed_port_url()
    first_down = put(box, 1, down, 1.0)
    second_down = put(box, 2, down, 2.0)
    up = put(box, 3, server.url, 3.0)
    assert main(["outbox", "flush", "--dir", str(box.root)]) == 1
    out = capsys.readouterr().out
    assert list(server.stored) == [up]
    waiting = [e.run_id for e in box.entries()]
    assert waiting == [first_down, second_down]  # still in order for the next flush
    assert box.load(second_down).attempts == 0  # not tried after the same server failed
    assert "1 newer entries for a server that just failed were not tried" in out


def test_broken_entry_files_are_skipped_with_a_warning(tmp_path: Path, server, capsys) -> None:
    box = Outbox(tmp_path / "outbox")
    good = put(box, 1, server.url, 1.0)
    bad_id = box.root / "evil.json"
    bad_id.write_text(json.dumps({"run_id": "../../etc/passwd", "url": server.url, "payload": {}, "created_at": 0}))
    (box.root / "torn.json").write_text('{"run_id": "abc", "url"')
    assert main(["outbox", "flush", "--dir", str(box.root)]) == 0
    out = capsys.readouterr().out
    assert list(server.stored) == [good]
    assert f"warning: {bad_id}: run id '../../etc/passwd' cannot name an outbox file: skipped" in out
    assert f"warning: {box.root / 'torn.json'}: not a robokit outbox entry (not JSON)" in out
    assert main(["outbox", "list", "--dir", str(box.root)]) == 0
    listed = capsys.readouterr().out
    assert "0 waiting" in listed and f"warning: {bad_id}: run id" in listed


@pytest.mark.parametrize("command", ["list", "flush"])
def test_a_missing_or_non_folder_dir_is_an_error(command: str, tmp_path: Path, capsys, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "afile").write_text("x")
    for path, why in ((tmp_path / "nowhere", "no such folder"), (tmp_path / "afile", "is not a folder")):
        assert main(["outbox", command, "--dir", str(path)]) == 2
        err = capsys.readouterr().err
        assert err == f"robokit: error: --dir {path}: {why}\n"
    # no --dir and no ./outbox yet: nothing was ever queued, which is not an error
    assert main(["outbox", command]) == 0
    assert "0 " in capsys.readouterr().out


def test_flush_url_is_checked(tmp_path: Path, capsys) -> None:
    (tmp_path / "outbox").mkdir()
    assert main(["outbox", "flush", "--dir", str(tmp_path / "outbox"), "--url", "http://h:99999/"]) == 2
    assert "robokit: error: --url 'http://h:99999/': not a valid URL (Port out of range" in capsys.readouterr().err


def test_a_filesystem_error_is_reported_as_one_not_as_a_connection_failure(tmp_path: Path, capsys) -> None:
    """failed/ is a file: the refused entry cannot be moved there. The error names the outbox file and the
    filesystem's reason."""
    box = Outbox(tmp_path / "outbox")
    srv = CourseServer(plan=lambda n: Answer(400, "no", store=False)).start()
    try:
        put(box, 1, srv.url, 1.0)
        (box.root / "failed").write_text("in the way")
        assert main(["outbox", "flush", "--dir", str(box.root)]) == 2
    finally:
        srv.stop()
    err = capsys.readouterr().err
    assert err.startswith(f"robokit: error: outbox {box.root / 'failed'}") and "cannot write" in err
    assert "connection" not in err and err.count("\n") == 1


def test_lock_files_do_not_pile_up(tmp_path: Path, server, monkeypatch) -> None:
    """Every delivered run leaves nothing behind: no entry, no lock file (not one lock per run)."""
    from robokit.config import load_config
    from robokit.plugin_api.plugins import load_plugins
    from robokit.runner import run_config

    monkeypatch.chdir(tmp_path)
    cfg_file = tmp_path / "c.toml"
    cfg_file.write_text('[world]\nmax_time = 0.05\n[bodies.box]\nshape = "box"\nposition = [0, 0, 0.5]\n'
                        f'[report.http]\nurl = "{server.url}"\nretries = 0\n')
    plugins = load_plugins()
    for _ in range(5):
        out = run_config(load_config(cfg_file, plugins), plugins)
        assert out.deliveries[-1][1].delivered
    assert len(server.stored) == 5
    box = Outbox(tmp_path / "outbox")
    assert not box.entries() and sorted(p.name for p in box.locks_dir.iterdir()) == []
    # a waiting entry keeps its lock file (two flushes must agree on one lock), and loses it once delivered
    waiting = put(box, 9, closed_port_url(), 1.0)
    box.flush(HttpSender())
    assert [p.name for p in box.locks_dir.iterdir()] == [f"{waiting}.lock"]
    box.flush(HttpSender(url=server.url))
    assert list(box.locks_dir.iterdir()) == [] and not box.entries()
