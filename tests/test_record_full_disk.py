"""The result first: on a disk with 12 kB left, the trace written during the loop is cut, and ``result.json`` is
still written (exit 6: the run succeeded, its record is incomplete). The disk is a real tmpfs of a fixed size,
mounted for the test (root only)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
ROBOKIT = [sys.executable, "-c", "import sys; from robokit.cli import main; sys.exit(main())"]


@pytest.fixture
def small_disk(tmp_path: Path) -> Iterator[Path]:
    """A 256 kB tmpfs with 12 kB left."""
    mount = tmp_path / "disk"
    mount.mkdir()
    if os.geteuid() != 0 or shutil.which("mount") is None:
        pytest.skip("mounting a small tmpfs needs root")
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=256k", "tmpfs", str(mount)], capture_output=True,
                          text=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.strip()}")
    try:
        free = shutil.disk_usage(mount).free
        (mount / "filler").write_bytes(b"\0" * (free - 12 * 1024))
        assert shutil.disk_usage(mount).free == 12 * 1024
        yield mount
    finally:
        subprocess.run(["umount", str(mount)], check=False)


@pytest.mark.skip_allowed("mounting a tmpfs needs root; CI runs as root")
@pytest.mark.parametrize("config", ["contact_stop", pytest.param("sort_robot", marks=pytest.mark.slow)])
def test_a_nearly_full_disk_cuts_the_trace_and_keeps_the_result(small_disk: Path, config: str) -> None:
    """contact_stop's trace is ~240 kB, its result ~2 kB; the sort's ~2.5 kB result is the issue's case."""
    done = subprocess.run(ROBOKIT + ["run", str(ROOT / "configs" / f"{config}.toml")], cwd=small_disk,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 6, (done.stdout[-2000:], done.stderr[-2000:])
    [folder] = list((small_disk / "results").iterdir())
    result = json.loads((folder / "result.json").read_text())
    assert result["outcome"] == "succeeded" and result["run_id"] == folder.name
    assert any("trace.jsonl" in w and "No space left on device" in w for w in result["warnings"])
    assert "trace.jsonl" in done.stdout and "result saved to" in done.stdout
    assert sorted(p.name for p in folder.iterdir() if p.name.startswith(".")) == []  # no reserve, no temp file
