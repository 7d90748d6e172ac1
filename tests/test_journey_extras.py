"""Every optional part fails cleanly: with an extra's modules hidden, each command that uses them ends with one line
saying what to install (``pip install 'robokit[EXTRA]'``, exit 2) before doing any work, never with "internal
error"; commands that can do without it (a sweep without matplotlib: no plots; the policy behaviour without
Gymnasium) still succeed.

The modules are hidden by a ``sys.meta_path`` finder that refuses them, in a fresh interpreter per command (the
same ``robokit.cli.main`` the console script runs).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DROP_TEST = ROOT / "configs" / "drop_test.toml"
HIDE = """
import sys

class Hidden:
    def find_spec(self, name, path=None, target=None):
        if name.partition(".")[0] in HIDDEN:
            raise ModuleNotFoundError(f"No module named {name!r} (hidden by the test)", name=name)
        return None

HIDDEN = set(sys.argv[1].split(","))
sys.meta_path.insert(0, Hidden())
from robokit.cli import main
sys.exit(main(sys.argv[2:]))
"""


def robokit_without(hidden: str, *args: str | Path, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-c", HIDE, hidden, *map(str, args)], cwd=cwd, capture_output=True,
                          text=True, timeout=300)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder holding one recorded run (1 s of the drop test, poses and trace)."""
    folder = tmp_path_factory.mktemp("extras")
    proc = subprocess.run([sys.executable, "-m", "robokit.cli", "run", str(DROP_TEST), "--max-time", "1",
                           "--quiet"], cwd=folder, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 1, proc.stderr  # max_time reached: aborted, recorded
    return folder


def assert_install_line(proc: subprocess.CompletedProcess[str], extra: str, module: str) -> None:
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert len(lines) == 1 and lines[0].startswith("robokit: error: "), proc.stderr
    assert module in lines[0] and f"pip install 'robokit[{extra}]'" in lines[0], lines[0]
    assert "internal error" not in proc.stderr and "Traceback" not in proc.stderr


VIDEO_COMMANDS = [
    ("imageio_ffmpeg", ("video", "last", "-o", "out.mp4")),
    ("imageio_ffmpeg", ("view", "last", "-o", "page.html")),
    ("matplotlib", ("view", "last", "--no-video", "-o", "page.html")),
    ("matplotlib", ("plot", "last", "-o", "plots")),
]


@pytest.mark.parametrize(("module", "args"), VIDEO_COMMANDS, ids=[" ".join(a[:3]) for _, a in VIDEO_COMMANDS])
def test_record_commands_say_what_to_install_before_any_work(recorded: Path, module: str, args: tuple[str, ...]):
    proc = robokit_without(module, *args, cwd=recorded)
    assert_install_line(proc, "video", module)
    assert not any((recorded / name).exists() for name in ("out.mp4", "page.html", "plots"))


def test_run_video_checks_before_it_simulates(tmp_path: Path) -> None:
    proc = robokit_without("imageio_ffmpeg", "run", DROP_TEST, "--video", "drop.mp4", cwd=tmp_path)
    assert_install_line(proc, "video", "imageio_ffmpeg")
    assert not (tmp_path / "results").exists() and proc.stdout == ""  # nothing ran, nothing was recorded


def test_the_video_extra_is_in_the_base_install() -> None:
    """The README's first command (``pip install .``) gives video, plots and the run page: the base dependencies
    name matplotlib and imageio-ffmpeg, and the old ``robokit[video]`` extra still exists (same modules)."""
    from robokit.config import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    names = {dep.split(">")[0].split("=")[0].split("[")[0].strip().lower() for dep in project["dependencies"]}
    assert {"matplotlib", "imageio-ffmpeg"} <= names
    assert "video" in project["optional-dependencies"]


SERVER_MODULES = ("django", "waitress", "whitenoise", "dj_database_url", "lxml", "django_q")


@pytest.mark.parametrize("module", SERVER_MODULES)
def test_serve_says_what_to_install(tmp_path: Path, module: str) -> None:
    proc = robokit_without(module, "serve", "--data", tmp_path / "data", "--port", "1", cwd=tmp_path)
    assert_install_line(proc, "server", module)
    assert not (tmp_path / "data").exists()  # before any work: no data folder, no database


def test_manage_says_what_to_install(tmp_path: Path) -> None:
    proc = robokit_without(",".join(SERVER_MODULES), "manage", "--data", tmp_path / "data", "create_class", "1반",
                           "--teacher", "t", cwd=tmp_path)
    assert_install_line(proc, "server", "django")


def test_the_policy_behaviour_runs_without_gymnasium(tmp_path: Path) -> None:
    proc = robokit_without("gymnasium", "run", ROOT / "configs" / "reach_policy.toml", "--quiet", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr


@pytest.mark.slow
def test_sweep_ray_backend_says_what_to_install(tmp_path: Path) -> None:
    proc = robokit_without("ray", "sweep", DROP_TEST, "--seeds", "0:1", "--backend", "ray", "--quiet",
                           "--out", tmp_path / "sweep", cwd=tmp_path)
    assert_install_line(proc, "ray", "Ray")


@pytest.mark.slow
def test_a_sweep_without_matplotlib_succeeds_without_plots(tmp_path: Path) -> None:
    proc = robokit_without("matplotlib", "sweep", DROP_TEST, "--seeds", "0:1", "--workers", "1", "--quiet",
                           "--out", tmp_path / "sweep", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "sweep" / "summary.md").exists() and not list((tmp_path / "sweep").glob("*.png"))
