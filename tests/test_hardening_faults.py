"""Faults at run time: Ctrl-C / SIGTERM at any point, plugins that exit, interrupt, block, return NaN or objects,
a wall-clock budget, a trace file that cannot be written. Each keeps the result and names what went wrong.

The plugins are a fake third-party distribution (see ``plugin_dists``). A plugin that "hangs" waits on an event
nobody sets; before it does, it writes a line into a FIFO the test reads, so the test sends its signal exactly
when the process is stuck there (no sleeps, no timing: the order is fixed by the FIFO).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import types
from pathlib import Path

import pytest
from plugin_dists import make_dist
from report_server import Answer, CourseServer

from robokit.cli import main

MISBEHAVING = '''
import os
import signal
import threading

from robokit import hookimpl
from robokit.components import Sensor
from robokit.config import Schema


class MisbehaveConfig(Schema):
    """``what``: what the sensor does at read ``at_read`` (0 = in setup); ``fifo``: told before hanging."""

    what: str = "nothing"
    at_read: int = 3
    fifo: str = ""


class Misbehaving(Sensor):
    """A third-party sensor with a fault chosen by config."""

    reading_type = float

    def setup(self, ctx):
        super().setup(ctx)
        self.reads = 0
        if self.config.at_read == 0:
            self._misbehave()

    def read(self):
        self.reads += 1
        if self.reads == self.config.at_read:
            return self._misbehave()
        if self.reads > self.config.at_read and self.config.what == "nan":
            return float("nan")
        return float(self.reads)

    def _misbehave(self):
        what = self.config.what
        if what == "hang":
            with open(self.config.fifo, "w") as fifo:
                fifo.write("stuck\\n")
            threading.Event().wait()  # a driver that never returns: only a signal gets out
        if what == "exit":
            raise SystemExit(7)
        if what == "keyboard":
            raise KeyboardInterrupt
        if what == "sigint":
            os.kill(os.getpid(), signal.SIGINT)  # as if Ctrl-C were pressed during this read
        if what == "sigterm":
            os.kill(os.getpid(), signal.SIGTERM)
        if what == "nan":
            return float("nan")
        if what == "object":
            return {"lock": threading.Lock()}
        return float(self.reads)


@hookimpl
def robokit_register_sensors(register):
    register("misbehaving", Misbehaving, MisbehaveConfig)
'''

SCENE = """
[world]
max_time = 2.0

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[bodies.ball]
shape = "sphere"
radius = 0.05
position = [0, 0, 0.5]

[sensors.probe]
type = "misbehaving"
rate_hz = 60
{options}

[behaviour]
type = "record"
components = ["probe"]
rate_hz = 60
duration = 1.0
"""


@pytest.fixture
def site(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The ``misbehave-dist 0.3`` distribution on sys.path (and PYTHONPATH); results/ in tmp_path."""
    make_dist(tmp_path / "site", "misbehave-dist", "0.3", MISBEHAVING)
    monkeypatch.syspath_prepend(str(tmp_path / "site"))
    monkeypatch.setenv("PYTHONPATH", str(tmp_path / "site"))
    monkeypatch.chdir(tmp_path)
    return tmp_path


def config(folder: Path, extra: str = "", **options: object) -> Path:
    lines = "\n".join(f"{k} = {json.dumps(v)}" for k, v in options.items())
    path = folder / "c.toml"
    path.write_text(SCENE.format(options=lines) + extra)
    return path


def stored(folder: Path) -> list[dict]:
    return [json.loads(p.read_text()) for p in sorted((folder / "results").rglob("*.json"))]


def spawn(args: list[str], cwd: Path) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-m", "robokit.cli", *args], cwd=cwd, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def wait_until_stuck(fifo: Path, proc: subprocess.Popen[str]) -> None:
    """Block until the plugin says (through the FIFO) that it is stuck; fail if the process ends first."""
    said: list[str] = []
    reader = threading.Thread(target=lambda: said.append(fifo.read_text()), daemon=True)
    reader.start()
    reader.join(600)  # a hang guard only: the plugin writes as soon as it gets there
    if not said:
        proc.kill()
        out, err = proc.communicate()
        pytest.fail(f"the plugin never got stuck: {err[-2000:]}")
    assert said == ["stuck\n"]


# ----------------------------------------------------------------- Ctrl-C and SIGTERM at any point
@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
@pytest.mark.parametrize("where", ["start-up", "loop"])
def test_a_signal_while_a_plugin_hangs_stops_the_run_and_keeps_the_result(site: Path, where: str,
                                                                           sig: signal.Signals) -> None:
    """Start-up: a plugin stuck in setup. Loop: a plugin stuck in read() — the loop cannot reach a tick boundary,
    so robokit breaks out of the call (after a short grace). Either way: exit 130, the result stored."""
    fifo = site / "stuck.fifo"
    os.mkfifo(fifo)
    cfg = config(site, what="hang", at_read=0 if where == "start-up" else 3, fifo=str(fifo))
    proc = spawn(["run", str(cfg), "--json"], site)
    wait_until_stuck(fifo, proc)
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=600)
    assert proc.returncode == 128 + sig, err  # 130 for SIGINT, 143 for SIGTERM
    assert "Traceback" not in err
    result = json.loads(out)
    assert result["interrupted"] is True and result["outcome"] == "aborted"
    assert f"interrupted by {sig.name}" in result["reason"]
    if where == "start-up":
        assert result["ticks"] == 0 and "during start-up" in result["reason"]
    else:
        assert result["ticks"] == 8  # reads at ticks 0 and 4 returned; tick 8 hung in read() and never finished
        assert result["result"]["recorded"] == {"probe": 2}  # the partial result
    (kept,) = stored(site)
    assert kept["run_id"] == result["run_id"] and kept["interrupted"] is True


@pytest.mark.parametrize("what, name, code", [("sigint", "SIGINT", 130), ("sigterm", "SIGTERM", 143)])
def test_a_signal_in_the_loop_stops_at_the_next_tick_boundary(site: Path, what: str, name: str, code: int,
                                                              capsys) -> None:
    cfg = config(site, what=what, at_read=3)
    assert main(["run", str(cfg), "--json"]) == code
    result = json.loads(capsys.readouterr().out)
    assert result["interrupted"] is True and result["reason"].startswith(f"interrupted by {name} at t = ")
    assert result["ticks"] == 9  # the read at tick 8 got the signal; tick 8 finished, then the loop stopped
    assert result["result"]["recorded"] == {"probe": 3}
    assert stored(site)[0]["run_id"] == result["run_id"]


def test_ctrl_c_during_delivery_retries_keeps_the_result_in_the_outbox(site: Path) -> None:
    """The server answers 503, then hangs on the retry: Ctrl-C there ends the process with 130 at once (no
    further retries: the server sees exactly two requests), the result stored locally and waiting in the outbox."""
    hung = threading.Event()
    server = CourseServer(on_request=lambda rec: hung.set() if len(server.requests) == 2 else None).start()
    server.script(Answer(503, store=False), Answer(stall=True, store=False))
    try:
        cfg = config(site, extra=f'\n[report.http]\nurl = "{server.url}"\nbackoff_factor = 0\n'
                                  "backoff_jitter = 0\nread_timeout = 60\n")
        proc = spawn(["run", str(cfg)], site)
        assert hung.wait(600), "the retry never arrived"  # a hang guard only
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=600)
    finally:
        server.stop()
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    assert len(server.requests) == 2 and not server.stored
    assert "outcome: succeeded" in out and "report[local]: result saved to results/" in out
    assert "report[http]: interrupted (SIGINT) while sending; result kept in the outbox" in out
    (entry_file,) = (site / "outbox").glob("*.json")
    entry = json.loads(entry_file.read_text())
    assert "interrupted" in entry["last_error"]
    (kept,) = stored(site)
    assert kept["run_id"] == entry["run_id"] == entry["payload"]["run_id"]


def test_after_ctrl_c_the_http_reporter_queues_without_sending(site: Path, capsys) -> None:
    """Ctrl-C in the loop: the user wants out, so the result goes to the outbox unsent (no network wait)."""
    server = CourseServer().start()
    try:
        cfg = config(site, extra=f'\n[report.http]\nurl = "{server.url}"\n', what="sigint", at_read=3)
        assert main(["run", str(cfg)]) == 130
    finally:
        server.stop()
    out = capsys.readouterr().out
    assert not server.requests
    assert "report[http]: not sent (interrupted); result kept in the outbox" in out
    (entry_file,) = (site / "outbox").glob("*.json")
    assert "interrupted" in json.loads(entry_file.read_text())["last_error"]


# ----------------------------------------------------------------- plugins that misbehave
@pytest.mark.parametrize("what, raised", [("exit", "SystemExit: 7"), ("keyboard", "KeyboardInterrupt")])
def test_system_exit_or_keyboard_interrupt_from_a_plugin_is_a_plugin_error(site: Path, what: str, raised: str,
                                                                           capsys) -> None:
    cfg = config(site, what=what, at_read=3)
    assert main(["run", str(cfg), "--json"]) == 3
    captured = capsys.readouterr()
    result = json.loads(captured.out)
    assert result["outcome"] == "error" and result["interrupted"] is False
    assert result["reason"].startswith(f"sensor 'probe' (type 'misbehaving' from misbehave-dist 0.3) raised during "
                                       f"read: {raised} (at site/misbehave_dist_")
    assert result["result"]["recorded"] == {"probe": 2}  # partial result kept
    (kept,) = stored(site)
    assert kept["outcome"] == "error" and kept["run_id"] == result["run_id"]
    trace_file = site / "results" / result["run_id"] / "traceback.txt"
    assert raised.split(":")[0] in trace_file.read_text()
    assert f"robokit: full traceback: {Path('results') / result['run_id'] / 'traceback.txt'}" in captured.err


def test_system_exit_in_a_real_process_is_exit_3_with_the_result(site: Path) -> None:
    cfg = config(site, what="exit", at_read=0)  # in setup
    proc = subprocess.run([sys.executable, "-m", "robokit.cli", "run", str(cfg)], cwd=site, capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 3, proc.stderr
    assert proc.stdout.startswith("outcome: error (sensors.probe: sensor type 'misbehaving' (misbehave-dist 0.3) "
                                  "raised during setup: SystemExit: 7 (at site/misbehave_dist_")
    assert "Traceback" not in proc.stderr
    (kept,) = stored(site)
    assert kept["outcome"] == "error" and kept["ticks"] == 0


def test_nan_readings_are_flagged_in_the_result_and_the_trace(site: Path, capsys) -> None:
    cfg = config(site, what="nan", at_read=3)
    trace = site / "trace.jsonl"
    assert main(["run", str(cfg), "--json", "--trace", str(trace)]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["outcome"] == "succeeded"
    # reads 3, 4, ... return NaN: 60 Hz for 1 s = reads at ticks 0, 4, ..., 240 -> 61 reads, 59 of them NaN
    assert result["warnings"] == ["sensor 'probe' (type 'misbehaving' from misbehave-dist 0.3) returned non-finite "
                                  "values in 59 of 61 reading(s) checked; first at tick 8 ((value))"]
    records = [json.loads(line) for line in trace.read_text().splitlines()]
    flagged = [r for r in records if r["kind"] == "nonfinite"]
    assert flagged == [{"tick": 8, "t": round(8 / 240, 6), "source": "probe", "kind": "nonfinite", "field": "(value)"}]


def test_a_reading_that_cannot_be_serialised_is_refused_naming_the_plugin(site: Path, capsys) -> None:
    cfg = config(site, what="object", at_read=3)
    assert main(["run", str(cfg), "--json"]) == 3
    result = json.loads(capsys.readouterr().out)
    assert result["outcome"] == "error"
    assert result["reason"] == ("sensor 'probe' (type 'misbehaving' from misbehave-dist 0.3) returned a reading that "
                                "cannot be serialised: lock is a lock (dict from read())")
    assert result["ticks"] == 8  # refused at the read of tick 8, which never finished


@pytest.fixture
def budget_after_the_hang(monkeypatch: pytest.MonkeyPatch) -> threading.Event:
    """Set the returned event when the plugin says it is stuck: only then does the wall-clock budget's timer start
    counting (it is still real wall time). A loaded machine therefore cannot spend the budget before the run
    reaches the hang, and the tick the run stops at does not depend on the machine's speed."""
    from robokit.process import interrupts

    stuck = threading.Event()

    class AfterTheHang(threading.Timer):
        def run(self) -> None:
            stuck.wait(600)  # a hang guard only: the plugin says so as soon as it gets there
            super().run()

    module = types.SimpleNamespace(**{k: getattr(threading, k) for k in dir(threading) if not k.startswith("__")})
    module.Timer = AfterTheHang
    monkeypatch.setattr(interrupts, "threading", module)
    return stuck


def drain_then(fifo: Path, stuck: threading.Event) -> None:
    """Read what the plugin writes before it hangs, then say it is stuck."""
    fifo.read_text()
    stuck.set()


@pytest.mark.slow
def test_max_wall_ends_a_run_stuck_in_a_plugin_naming_it(site: Path, capsys, budget_after_the_hang) -> None:
    """A plugin that never returns: the wall-clock budget ends the run (aborted, exit 1), result kept, and the
    summary names the component the time went to."""
    fifo = site / "stuck.fifo"
    os.mkfifo(fifo)
    drain = threading.Thread(target=drain_then, args=(fifo, budget_after_the_hang), daemon=True)
    drain.start()
    cfg = config(site, what="hang", at_read=3, fifo=str(fifo))
    assert main(["run", str(cfg), "--json", "--max-wall", "1"]) == 1
    result = json.loads(capsys.readouterr().out)
    assert result["outcome"] == "aborted" and result["interrupted"] is False
    assert result["reason"].startswith("max_wall_time 1 s (wall clock) reached at t = 0.033 s; slowest: sensor "
                                       "'probe' (type 'misbehaving' from misbehave-dist 0.3) ")
    assert result["reason"].endswith("in 3 call(s) (stopped inside it)")
    assert result["ticks"] == 8 and result["result"]["recorded"] == {"probe": 2}
    assert stored(site)[0]["outcome"] == "aborted"


@pytest.mark.slow  # the slow tier: the default tier keeps its two-minute budget
def test_world_max_wall_time_from_the_config(site: Path, capsys, budget_after_the_hang) -> None:
    fifo = site / "stuck.fifo"
    os.mkfifo(fifo)
    threading.Thread(target=drain_then, args=(fifo, budget_after_the_hang), daemon=True).start()
    cfg = config(site, what="hang", at_read=2, fifo=str(fifo))
    cfg.write_text(cfg.read_text().replace("max_time = 2.0", "max_time = 2.0\nmax_wall_time = 0.5"))
    assert main(["run", str(cfg), "--json"]) == 1
    result = json.loads(capsys.readouterr().out)
    assert result["reason"].startswith("max_wall_time 0.5 s (wall clock) reached")


def test_a_failing_trace_writer_is_named_and_not_blamed_on_the_behaviour(site: Path, capsys) -> None:
    """/dev/full accepts the open and fails every write (ENOSPC): the run goes on, the trace writer is named."""
    cfg = config(site, what="nothing")
    assert main(["run", str(cfg), "--trace", "/dev/full"]) == 6  # succeeded, the result kept, a record incomplete
    out = capsys.readouterr().out
    assert "outcome: succeeded" in out
    assert "warning: trace writer: writing /dev/full failed at tick 0: No space left on device; the trace stops " \
           "there" in out
    assert stored(site)[0]["warnings"][0].startswith("trace writer: writing /dev/full failed")
