"""Running a submission's official trials in a separate, limited process.

The parent (a queue worker) starts ``python -m robokit.server.sandbox`` with the trials on stdin; the child sets
its resource limits before it imports robokit, runs each trial with :func:`robokit.sweep.trial.run_trial_safely`
(the sweep's code: config text + seed -> one row) and writes one JSON row per finished trial to stdout.

At submit time the web process starts the same child to check a config that names a student's plugin types
(:func:`check_sandboxed`): the child imports the student's modules as extra plugins, loads the config as a trial
would, and writes one JSON line (valid, or the key and message), within :data:`CHECK_SECONDS`.

What isolation there is (said plainly in docs/server.md):

- a separate process, started fresh for each submission, in a new empty scratch folder (its working directory,
  ``HOME`` and ``TMPDIR``), deleted afterwards; an environment with nothing of the server's (no secret key, no
  database URL);
- ``setrlimit``: CPU seconds (the trials' time limits plus a margin; the kernel kills the process past it), address
  space (``ROBOKIT_SANDBOX_MEMORY_MB``, default 3072), size of any file it writes (64 MiB), no core files;
- a wall-clock limit per trial (robokit's own ``world.max_wall_time``: the trial ends ``aborted``), and one for the
  whole process (the parent kills it);
- no network when the machine lets an unprivileged user make a network namespace (``unshare --net
  --map-root-user``: only a loopback device, down); otherwise the process has the server's network.

It is not a security boundary against hostile code: the process runs as the server's user and can read what that
user can read. Students submit configs, and their own plugin package (Python code) only where the assignment allows
it: that code runs here, inside these limits and nowhere else.
"""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import subprocess
import sys
import tempfile
import threading
from collections.abc import Iterator, Sequence
from functools import cache
from typing import Any

FILE_LIMIT = 64 << 20
MEMORY_MB = int(os.environ.get("ROBOKIT_SANDBOX_MEMORY_MB", 3072))
CPU_MARGIN = 30
WALL_MARGIN = 30
"""Seconds the whole process may take beyond its trials' limits (start-up, loading plugins) before it is killed."""
CHECK_SECONDS = 30.0
"""Wall and CPU seconds for checking a submitted config with the student's plugin (start-up included)."""


def wall_limit(trials: int, trial_seconds: float) -> float:
    """The wall-clock limit of a process that runs ``trials`` trials of at most ``trial_seconds`` each."""
    return trials * trial_seconds + WALL_MARGIN


@cache
def network_isolation() -> bool:
    """Whether ``unshare --net --map-root-user`` works here (an unprivileged network namespace)."""
    if sys.platform != "linux" or shutil.which("unshare") is None:
        return False
    try:
        return subprocess.run(["unshare", "--net", "--map-root-user", "true"], capture_output=True,
                              timeout=10).returncode == 0
    except (OSError, subprocess.SubprocessError):
        return False


def sandbox_command() -> list[str]:
    """The command that starts the child: ``python -m robokit.server.sandbox``, in a new network namespace
    when the machine allows it."""
    cmd = [sys.executable, "-m", "robokit.server.sandbox"]
    return ["unshare", "--net", "--map-root-user", *cmd] if network_isolation() else cmd


def run_sandboxed(tasks: Sequence[Any], trial_seconds: float,
                  files: dict[str, str] | None = None) -> Iterator[dict[str, Any]]:
    """Yield one row per task (:class:`robokit.sweep.trial.TrialTask`), as each trial ends, from a fresh
    limited process. A trial the process did not finish (it hit a limit or died) gets an ``error`` row.
    ``files`` (a student's plugin package, paths checked by :mod:`robokit.server.plugin_upload`) are written into
    the scratch folder, the process's working directory, where the tasks' ``plugins`` modules are imported from."""
    from robokit.sweep.trial import error_row

    scratch = scratch_folder(files or {})
    sent = [{**{f.name: getattr(t, f.name) for f in dataclasses.fields(t) if f.name not in ("before", "after")},
             "base_dir": scratch} for t in tasks]
    cpu = int(len(tasks) * trial_seconds) + CPU_MARGIN
    done: set[str] = set()
    child = None
    try:
        child = _Child(scratch, {"tasks": sent, "limits": _limits(cpu)}, wall_limit(len(tasks), trial_seconds))
        for line in child.lines():
            if line.strip():
                row = json.loads(line)
                done.add(row["key"])
                yield row
        why = child.finish()
        for t in tasks:
            if t.key not in done:
                yield error_row(t, f"the evaluation process ended before this trial finished ({why})")
    finally:
        if child is not None:
            child.close()  # the caller stopped reading early: nothing of it may run on
        shutil.rmtree(scratch, ignore_errors=True)


def check_sandboxed(config_text: str, source: str, overrides: dict[str, Any], files: dict[str, str],
                    modules: Sequence[str], seconds: float | None = None) -> tuple[str, str] | None:
    """Load a config with a student's plugin package the way a trial does (the modules imported as extra plugins,
    then robokit's config check), in a fresh limited process of at most ``seconds`` (wall and CPU; default
    :data:`CHECK_SECONDS`).

    Returns:
        None for a config that loads; otherwise ``(field, message)``: the key robokit's check names, or
        ``plugin`` when the package could not be imported or the process hit a limit.
    """
    seconds = CHECK_SECONDS if seconds is None else seconds
    scratch = scratch_folder(files)
    child = None
    request = {"check": {"config_text": config_text, "source": source, "base_dir": scratch,
                         "overrides": overrides, "plugins": list(modules)},
               "limits": _limits(max(1, int(seconds)))}
    try:
        child = _Child(scratch, request, seconds)
        answer = "".join(child.lines()).strip()
        why = child.finish()
    finally:
        if child is not None:
            child.close()
        shutil.rmtree(scratch, ignore_errors=True)
    if not answer:
        return "plugin", f"loading your plugin and the config did not finish in {seconds:g} s ({why})"
    try:
        problem = json.loads(answer.splitlines()[-1])
        return None if problem.get("ok") is True else (str(problem["field"]), str(problem["message"]))
    except (ValueError, KeyError, AttributeError):  # the student's code wrote to the answer's stream
        return "plugin", f"the check of your plugin gave no readable answer ({why})"


def scratch_folder(files: dict[str, str]) -> str:
    """A new scratch folder holding only ``files`` (``{relative path: text}``); the caller deletes it."""
    scratch = tempfile.mkdtemp(prefix="robokit-eval-")
    try:
        _write_files(scratch, files)
    except BaseException:
        shutil.rmtree(scratch, ignore_errors=True)
        raise
    return scratch


def _limits(cpu: int) -> dict[str, int]:
    return {"cpu": cpu, "memory_mb": MEMORY_MB, "file": FILE_LIMIT}


class _Child:
    """The limited child process, started in ``scratch`` with ``request`` on its stdin and killed after
    ``wall`` seconds."""

    def __init__(self, scratch: str, request: dict[str, Any], wall: float) -> None:
        env = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "HOME": scratch, "TMPDIR": scratch,
               "LANG": "C.UTF-8", "MPLBACKEND": "Agg", "PYTHONDONTWRITEBYTECODE": "1"}
        self.proc = subprocess.Popen(sandbox_command(), stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, cwd=scratch, env=env, text=True)
        self.timer = threading.Timer(wall, self.proc.kill)
        self.timer.start()
        assert self.proc.stdin is not None and self.proc.stderr is not None
        self.err = _Collect(self.proc.stderr)
        self.proc.stdin.write(json.dumps(request))
        self.proc.stdin.close()

    def lines(self) -> Iterator[str]:
        """The child's stdout, line by line, as it writes them."""
        assert self.proc.stdout is not None
        yield from self.proc.stdout

    def finish(self) -> str:
        """Wait for the child; why it ended (for messages)."""
        code = self.proc.wait()
        self.timer.cancel()
        self.err.join()
        return _why(code, self.err.text)

    def close(self) -> None:
        """Kill the child if it still runs."""
        self.timer.cancel()
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()


def _write_files(scratch: str, files: dict[str, str]) -> None:
    root = os.path.realpath(scratch)
    for rel, source in files.items():
        path = os.path.join(root, *rel.split("/"))
        if os.path.commonpath([root, os.path.realpath(path)]) != root:
            raise ValueError(f"{rel!r} is outside the scratch folder")
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(source)


class _Collect(threading.Thread):
    """Reads a pipe to the end (the child's stderr), keeping the last few kilobytes."""

    def __init__(self, pipe: Any) -> None:
        super().__init__(daemon=True)
        self.pipe, self.text = pipe, ""
        self.start()

    def run(self) -> None:
        for line in self.pipe:
            self.text = (self.text + line)[-4000:]


def _why(code: int, stderr: str) -> str:
    if code == -9:
        return "killed: CPU or wall-clock limit reached"
    if code in (-24, 152):
        return "CPU time limit reached"
    last = stderr.strip().splitlines()[-1] if stderr.strip() else ""
    return f"exit code {code}{': ' + last[:300] if last else ''}"


def _limit(resource_mod: Any, which: int, value: int) -> None:
    """Soft and hard limit ``value`` (or the existing hard limit, if that is lower: it cannot be raised)."""
    _, hard = resource_mod.getrlimit(which)
    if hard != resource_mod.RLIM_INFINITY:
        value = min(value, hard)
    resource_mod.setrlimit(which, (value, value))


def apply_limits(limits: dict[str, int]) -> None:
    """Set this process's resource limits (soft = hard, so it cannot raise them again)."""
    import resource

    _limit(resource, resource.RLIMIT_CPU, limits["cpu"])
    _limit(resource, resource.RLIMIT_AS, limits["memory_mb"] << 20)
    _limit(resource, resource.RLIMIT_FSIZE, limits["file"])
    _limit(resource, resource.RLIMIT_CORE, 0)


def main() -> int:
    """The child: limits first, then the trials (one JSON row per line on the original stdout) or the config
    check (one JSON line: ``{"ok": true}`` or the field and message)."""
    request = json.loads(sys.stdin.read())
    apply_limits(request["limits"])
    out = os.fdopen(os.dup(1), "w", encoding="utf-8")
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)  # pybullet prints its banner at C level: keep the rows' stream clean
    if "check" in request:
        from robokit.server.submitted import config_problem

        check = request["check"]
        problem = config_problem(check["config_text"], check["source"], check["base_dir"], check["overrides"],
                                 tuple(check["plugins"]))
        out.write(json.dumps({"ok": True} if problem is None else {"field": problem[0], "message": problem[1]}))
        out.flush()
        return 0
    from robokit.sweep.trial import TrialTask, run_trial_safely

    for fields in request["tasks"]:
        fields["plugins"] = tuple(fields.get("plugins") or ())
        row = run_trial_safely(TrialTask(**fields))
        out.write(json.dumps(row, separators=(",", ":")) + "\n")
        out.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
