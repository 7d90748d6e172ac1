"""Bad files and nonsense numbers: one line naming the path (or key), exit 2, never a traceback.

Most cases go through ``robokit.cli.main`` in-process (the same code path as the command); a sample runs the real
command in a fresh process, where a traceback would really reach the terminal.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from robokit.cli import main

SCENE = '[bodies.box]\nshape = "box"\nposition = [0, 0, 0.5]\n'


def one_error_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("robokit: error: ")
    return lines[0]


def _binary(p: Path) -> None:
    p.write_bytes(bytes(range(256)) * 4)


def _latin1(p: Path) -> None:
    p.write_bytes('[bodies.caf\xe9]\nshape = "box"\n'.encode("latin-1"))


def _empty(p: Path) -> None:
    p.write_bytes(b"")


def _comments(p: Path) -> None:
    p.write_text("# a config that says nothing\n\n   # still nothing\n")


def _folder(p: Path) -> None:
    p.mkdir()


def _too_large(p: Path) -> None:
    with p.open("wb") as fh:
        fh.truncate(5 * 1024 * 1024)  # sparse: 5 MB of NUL, more than a config can be


def _socket(p: Path) -> None:  # unreadable even for root: open() on a socket fails (ENXIO)
    s = socket.socket(socket.AF_UNIX)
    s.bind(str(p))
    s.close()


def _syntax(p: Path) -> None:
    p.write_text("[world\nmax_time = 1\n")


def _world_only(p: Path) -> None:
    p.write_text("[world]\nmax_time = 1.0\n")


BAD_FILES = {
    "binary": (_binary, "not a text file"),
    "latin1": (_latin1, "not UTF-8 text (byte 0xe9 on line 1)"),
    "empty": (_empty, "the file is empty"),
    "comments_only": (_comments, "the file is empty"),
    "folder": (_folder, "is a folder"),
    "too_large": (_too_large, "too large for a config"),
    "socket": (_socket, "cannot read"),
    "syntax": (_syntax, "TOML syntax error"),
    "nothing_to_run": (_world_only, "nothing to run"),
    "missing": (None, "file not found"),
}


@pytest.mark.parametrize("command", ["validate", "run"])
@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_a_bad_file_is_one_line_naming_it_and_exit_2(case: str, command: str, tmp_path: Path, capsys,
                                                     monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    make, expected = BAD_FILES[case]
    path = tmp_path / f"{case}.toml"
    if make is not None:
        make(path)
    assert main([command, str(path)]) == 2
    line = one_error_line(capsys)
    assert line.startswith(f"robokit: error: {path}: ") and expected in line
    assert not (tmp_path / "results").exists()  # nothing ran, nothing was stored


def test_unreadable_file_for_a_normal_user(tmp_path: Path, capsys) -> None:
    if os.geteuid() == 0:  # root reads anything; the socket case above covers "cannot read" for root
        path = tmp_path / "sock.toml"
        _socket(path)
    else:
        path = tmp_path / "locked.toml"
        path.write_text(SCENE)
        path.chmod(0)
    assert main(["validate", str(path)]) == 2
    assert "cannot read" in one_error_line(capsys)


NONSENSE = {
    "world.gravity nan": ("[world]\ngravity = [0, 0, nan]\n" + SCENE, "world.gravity.2", "finite"),
    "world.gravity 1e308": ("[world]\ngravity = [0, 0, -1e308]\n" + SCENE, "world.gravity.2", "-1000"),
    "world.max_time inf": ("[world]\nmax_time = inf\n" + SCENE, "world.max_time", "finite"),
    "world.gui string": ('[world]\ngui = "no"\n' + SCENE, "world.gui", "valid boolean"),
    "world.gui int": ("[world]\ngui = 0\n" + SCENE, "world.gui", "valid boolean"),
    "world.seed bool": ("[world]\nseed = true\n" + SCENE, "world.seed", "valid integer"),
    "world.seed float": ("[world]\nseed = 1.5\n" + SCENE, "world.seed", "valid integer"),
    "world.time_step string": ('[world]\ntime_step = "0.01"\n' + SCENE, "world.time_step", "valid number"),
    "body position nan": ('[bodies.b]\nshape = "box"\nposition = [nan, 0, 0]\n', "bodies.b.position.0", "finite"),
    "body position inf": ('[bodies.b]\nshape = "box"\nposition = [0, inf, 0]\n', "bodies.b.position.1", "finite"),
    "body position 1e308": ('[bodies.b]\nshape = "box"\nposition = [0, 0, 1e308]\n', "bodies.b.position.2",
                            "10000"),
    "body mass inf": (SCENE + "mass = inf\n", "bodies.box.mass", "finite"),
    "body mass true": (SCENE + "mass = true\n", "bodies.box.mass", "valid number"),
    "box size zero": (SCENE + "size = [0.1, 0, 0.1]\n", "bodies.box.size.1", "greater than 0"),
    "box size negative": (SCENE + "size = [-0.1, 0.1, 0.1]\n", "bodies.box.size.0", "greater than 0"),
    "box size nan": (SCENE + "size = [0.1, 0.1, nan]\n", "bodies.box.size.2", "finite"),
    "rgba 0-255": (SCENE + "rgba = [255, 0, 0, 255]\n", "bodies.box.rgba", "0-1 floats"),
    "rgba nan": (SCENE + "rgba = [1, 0, nan, 1]\n", "bodies.box.rgba.2", "finite"),
    "rgba negative": (SCENE + "rgba = [1, -0.5, 0, 1]\n", "bodies.box.rgba.1", "greater than or equal to 0"),
    "restitution above 1": (SCENE + "restitution = 1.5\n", "bodies.box.restitution", "less than or equal to 1"),
    "event force nan": (SCENE + '[[events]]\nat = 0.1\ntype = "force"\nbody = "box"\nforce = [nan, 0, 0]\n',
                        "events[0].force.0", "finite"),
    "sensor rate nan": (SCENE + '[sensors.p]\ntype = "body_pose"\nrate_hz = nan\n', "sensors.p.rate_hz",
                        "finite"),
    "behaviour rate inf": (SCENE + '[behaviour]\ntype = "drop_test"\nrate_hz = inf\n', "behaviour.rate_hz",
                           "finite"),
    "plugin float bool": (SCENE + '[sensors.c]\ntype = "contact"\nbody = "box"\nmin_force = true\n',
                          "sensors.c.min_force", "valid number"),
    "plugin int float": (SCENE + '[sensors.c]\ntype = "camera"\nwidth = 320.5\n', "sensors.c.width",
                         "valid integer"),
    "plugin float 1e308": (SCENE + '[sensors.c]\ntype = "contact"\nbody = "box"\nmin_force = 1e308\n',
                           "sensors.c.min_force", "1000000000"),
    "report student number": (SCENE + "[report]\nstudent = 5\n", "report.student", "valid string"),
    "report keep_local string": (SCENE + '[report]\nkeep_local = "yes"\n', "report.keep_local", "valid boolean"),
}


@pytest.mark.parametrize("case", sorted(NONSENSE))
def test_nonsense_numbers_and_coercions_are_refused(case: str, tmp_path: Path, capsys) -> None:
    text, key, expected = NONSENSE[case]
    path = tmp_path / "c.toml"
    path.write_text(text)
    assert main(["validate", str(path)]) == 2
    line = one_error_line(capsys)
    assert f"{path}: {key}: " in line and expected in line


def test_an_integer_is_still_a_float_and_containers_stay_lax(tmp_path: Path, capsys) -> None:
    """TOML writes ``1`` for 1.0: strict types must not refuse it (nor a list for a tuple)."""
    path = tmp_path / "c.toml"
    path.write_text("[world]\ngravity = [0, 0, -10]\nmax_time = 1\n" + SCENE + "mass = 2\nsize = [1, 1, 1]\n")
    assert main(["validate", str(path)]) == 0
    from robokit.config import load_config
    from robokit.plugin_api.plugins import load_plugins

    cfg = load_config(path, load_plugins())
    assert cfg.world.gravity == (0.0, 0.0, -10.0) and isinstance(cfg.world.max_time, float)
    assert cfg.bodies["box"].mass == 2.0 and cfg.bodies["box"].size == (1.0, 1.0, 1.0)


def test_third_party_schemas_inherit_the_rules() -> None:
    """A plugin's own Schema subclass gets strict types and finite floats without asking."""
    from pydantic import ValidationError

    from robokit.config import Schema

    class Gain(Schema):
        kp: float = 1.0
        enabled: bool = True
        taps: int = 3

    assert Gain.model_validate({"kp": 2, "taps": 4}).kp == 2.0
    for bad in ({"kp": float("nan")}, {"kp": float("inf")}, {"kp": True}, {"enabled": "no"}, {"enabled": 1},
                {"taps": 2.0}, {"taps": False}, {"kp": 1e300}):
        with pytest.raises(ValidationError):
            Gain.model_validate(bad)


@pytest.mark.parametrize("args, expected", [
    (["run", "{cfg}", "--max-time", "nan"], "argument --max-time: expected a positive, finite number"),
    (["run", "{cfg}", "--max-time", "inf"], "argument --max-time: expected a positive, finite number"),
    (["run", "{cfg}", "--max-wall", "-1"], "argument --max-wall: expected a positive, finite number"),
    (["run", "{cfg}", "--seed", "1.5"], "argument --seed: invalid int value"),
    (["run", "{cfg}", "--seed", "-3"], "world.seed: input should be greater than or equal to 0"),
    (["run", "{cfg}", "--report-url", "http://:80/x"], "report.http.url: the URL has no host name"),
    (["run", "{cfg}", "--report-url", "http://host:99999/x"], "report.http.url: not a valid URL"),
    (["run", "{cfg}", "--report-url", "http://host/a b"], "report.http.url: a URL cannot contain spaces"),
    (["run", "{cfg}", "--report-url", "http://[::1/x"], "report.http.url: not a valid URL"),
    (["run", "{cfg}", "--report-url", "ftp://host/x"], "report.http.url: expected an http:// or https:// URL"),
    (["run", "{cfg}", "--trace", "{tmp}"], "--trace {tmp}: is a folder"),
    (["run", "{cfg}", "--trace", "{tmp}/no/such/dir/t.jsonl"], "the folder {tmp}/no/such/dir does not exist"),
    (["frobnicate"], "invalid choice: 'frobnicate'"),
    (["run"], "the following arguments are required: config"),
])
def test_bad_command_lines_are_one_line_and_exit_2(args: list[str], expected: str, tmp_path: Path, capsys,
                                                   monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    cfg = tmp_path / "c.toml"
    cfg.write_text(SCENE)
    argv = [a.format(cfg=cfg, tmp=tmp_path) for a in args]
    code = None
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's usage errors
        code = exc.code
    assert code == 2
    line = one_error_line(capsys)
    assert expected.format(tmp=tmp_path) in line
    assert not (tmp_path / "results").exists()


@pytest.mark.skip_allowed("as root, only a writable-looking /sys leaves nothing read-only to write into")
def test_trace_into_a_read_only_folder_is_refused_before_the_run(tmp_path: Path, capsys, monkeypatch) -> None:
    if os.geteuid() == 0:  # root writes anywhere but on a read-only filesystem (sysfs is one in containers)
        target = "/sys/robokit-trace.jsonl"
        if os.access("/sys", os.W_OK) and not Path("/sys").is_mount():
            pytest.skip("no read-only filesystem to write into as root")
    else:
        locked = tmp_path / "ro"
        locked.mkdir()
        locked.chmod(0o500)
        target = str(locked / "t.jsonl")
    monkeypatch.chdir(tmp_path)
    cfg = tmp_path / "c.toml"
    cfg.write_text(SCENE)
    assert main(["run", str(cfg), "--trace", target]) == 2
    assert f"--trace {target}: cannot write" in one_error_line(capsys)
    assert not (tmp_path / "results").exists()


def _cli(args: list[str], cwd: Path, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "robokit.cli", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=300, env=env)


def test_the_real_command_prints_one_line_for_bad_files(tmp_path: Path) -> None:
    for name, make in (("bin.toml", _binary), ("latin.toml", _latin1), ("empty.toml", _empty)):
        make(tmp_path / name)
        proc = _cli(["run", name], tmp_path)
        assert proc.returncode == 2
        assert proc.stderr.count("\n") == 1 and proc.stderr.startswith(f"robokit: error: {name}: "), proc.stderr
        assert proc.stdout == ""
    (tmp_path / "nan.toml").write_text("[world]\nmax_time = nan\n" + SCENE)
    proc = _cli(["validate", "nan.toml"], tmp_path)
    assert proc.returncode == 2 and proc.stderr == "robokit: error: nan.toml: world.max_time: input should be a " \
                                                   "finite number, got nan\n"


CRASHING_SCHEMA = '''
from pydantic import field_validator

from robokit import hookimpl
from robokit.components import Sensor
from robokit.config import Schema


class BuggyConfig(Schema):
    """Its validator has a bug: a TypeError is not a validation error."""

    gain: float = 1.0

    @field_validator("gain")
    @classmethod
    def _check(cls, value):
        return value + "oops"


class Buggy(Sensor):
    """A sensor with a buggy schema."""

    reading_type = float

    def read(self):
        return 0.0


@hookimpl
def robokit_register_sensors(register):
    register("buggy", Buggy, BuggyConfig)
'''


@pytest.mark.slow
def test_an_unexpected_exception_is_one_line_with_a_traceback_file(tmp_path: Path) -> None:
    """A bug (here a plugin schema's validator raising TypeError) gives one line naming where it raised and the
    file holding the full traceback; --debug and ROBOKIT_DEBUG=1 print the traceback too."""
    from plugin_dists import make_dist

    module = make_dist(tmp_path / "site", "buggy-dist", "0.1", CRASHING_SCHEMA)
    (tmp_path / "c.toml").write_text(SCENE + '[sensors.b]\ntype = "buggy"\ngain = 2\n')
    env = {**os.environ, "PYTHONPATH": str(tmp_path / "site"), "TMPDIR": str(tmp_path)}
    env.pop("ROBOKIT_DEBUG", None)
    proc = _cli(["validate", "c.toml"], tmp_path, env)
    assert proc.returncode == 3
    assert "Traceback" not in proc.stderr and proc.stderr.count("\n") == 1, proc.stderr
    line = proc.stderr.strip()
    assert line.startswith("robokit: internal error: TypeError: unsupported operand type(s) for +")
    assert f"(at site/{module}.py:17)" in line  # the plugin's file and line, relative to the working folder
    written = Path(line.rsplit("full traceback: ", 1)[1])
    assert written.parent == tmp_path and "Traceback (most recent call last)" in written.read_text()
    for debug_args, debug_env in ((["--debug"], {}), ([], {"ROBOKIT_DEBUG": "1"})):
        proc = _cli(["validate", "c.toml", *debug_args], tmp_path, {**env, **debug_env})
        assert proc.returncode == 3
        assert "Traceback (most recent call last)" in proc.stderr and 'return value + "oops"' in proc.stderr
        assert proc.stderr.splitlines()[-1].startswith("robokit: internal error: TypeError")
