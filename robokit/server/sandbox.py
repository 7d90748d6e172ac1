"""Running a submission's official trials in a separate, limited process.

The parent (a queue worker) starts ``python -m robokit.server.sandbox`` with the trials on stdin; the child sets
its resource limits before it imports robokit, runs each trial with :func:`robokit.sweep.trial.run_trial_safely`
(the sweep's code: config text + seed -> one row) and writes one JSON row per finished trial to stdout.

At submit time the web process starts the same child to check a config that names a student's plugin types
(:func:`check_sandboxed`): the child imports the student's modules as extra plugins, loads the config as a trial
would, and writes one JSON line (valid, or the key and message), within :data:`CHECK_SECONDS`.

What decides a trial's outcome is a function of the submission and the seed, never of the machine's load:

- the config's simulated-time limit (``world.max_time``) and the trial's own CPU time: a trial whose thread has used
  the assignment's ``trial_seconds`` of processor time is stopped at the next tick (outcome ``aborted``, the reason
  says so); one stuck inside a single step for :data:`CPU_GRACE` more CPU seconds is stopped by the kernel
  (``RLIMIT_CPU``), and that trial is ``aborted`` too. A submitted ``world.max_wall_time`` is set aside.
- a wall-clock limit per trial remains as a safety net (:func:`trial_wall_limit`, generous): when it trips, the
  process is killed and :class:`Requeue` is raised — an infrastructure failure, never a graded row; the trials not
  finished go back to the queue. So does a child killed by anything but its own limits.

What isolation there is (said plainly in docs/server.md):

- a separate process, started fresh for each submission in its own session (a Ctrl-C meant for the server does not
  reach it; it ends when its parent does), in a new empty scratch folder (its working directory, ``HOME`` and
  ``TMPDIR``), deleted afterwards; an environment with nothing of the server's (no secret key, no database URL);
- ``setrlimit``: CPU seconds (each trial's budget, and all trials' plus a margin for the whole process), address
  space (``ROBOKIT_SANDBOX_MEMORY_MB``, default 3072), size of any file it writes (64 MiB), no core files;
- no network when the machine lets an unprivileged user make a network namespace (``unshare --net
  --map-root-user``: only a loopback device, down); otherwise the process has the server's network.

It is not a security boundary against hostile code: the process runs as the server's user and can read what that
user can read. Students submit configs, and their own plugin package (Python code) only where the assignment allows
it: that code runs here, inside these limits and nowhere else.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator, Sequence
from functools import cache
from typing import Any

FILE_LIMIT = 64 << 20
MEMORY_MB = int(os.environ.get("ROBOKIT_SANDBOX_MEMORY_MB", 3072))
CPU_MARGIN = 30
"""CPU seconds the whole process may use beyond its trials' budgets (start-up, loading plugins)."""
CPU_GRACE = 5
"""CPU seconds a trial may run past its budget inside one step before the kernel stops the process (SIGXCPU)."""
CPU_POLL = 0.05
"""Wall seconds between two looks at a running trial's CPU time."""
WALL_FACTOR = 10.0
WALL_MARGIN = 60.0
"""The wall-clock safety net of one trial: ``WALL_FACTOR`` times its CPU allowance, plus ``WALL_MARGIN``."""
CHECK_SECONDS = 30.0
"""Wall and CPU seconds for checking a submitted config with the student's plugin (start-up included)."""
SCRATCH_PREFIX = "robokit-eval-"
STALE_UNNAMED = 24 * 3600.0
"""Age after which a scratch folder without a process id in its name counts as left behind."""


class Requeue(Exception):
    """The evaluation could not finish for a reason that is not the submission's (the wall-clock safety net
    tripped, the process was killed from outside): the trials without a row go back to the queue."""


def trial_wall_limit(trial_seconds: float) -> float:
    """The wall-clock safety net of one trial whose CPU budget is ``trial_seconds`` (start-up included)."""
    return WALL_FACTOR * (trial_seconds + CPU_GRACE) + WALL_MARGIN


def process_cpu_limit(trials: int, trial_seconds: float) -> int:
    """The CPU seconds of a process that runs ``trials`` trials of ``trial_seconds`` of CPU each."""
    return int(trials * (trial_seconds + CPU_GRACE)) + CPU_MARGIN


def budget_reason(trial_seconds: float) -> str:
    """What stops a trial over its CPU budget (the run's reason reads "interrupted by <this> at t = ... s")."""
    return f"its CPU-time budget ({trial_seconds:g} s of processor time)"


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


def official_task(task: Any, trial_seconds: float) -> Any:
    """``task`` with the CPU-time budget armed around its run (the hooks are plain functions: they pickle, so the
    same task runs in the sandbox or on a Ray worker)."""
    return dataclasses.replace(task, before=functools.partial(start_cpu_budget, float(trial_seconds)),
                               after=stop_cpu_budget)


def run_sandboxed(tasks: Sequence[Any], trial_seconds: float,
                  files: dict[str, str] | None = None) -> Iterator[dict[str, Any]]:
    """Yield one row per task (:class:`robokit.sweep.trial.TrialTask`), as each trial ends, from fresh limited
    processes (a process that ends during a trial is replaced for the trials after it). ``trial_seconds`` is each
    trial's CPU budget. ``files`` (a student's plugin package, paths checked by :mod:`robokit.server.plugin_upload`)
    are written into the scratch folder, the process's working directory, where the tasks' ``plugins`` modules are
    imported from.

    Raises:
        Requeue: the wall-clock safety net tripped, or the process was killed from outside; the rows yielded so far
            stand, the rest of the trials have none.
    """
    from robokit.sweep.trial import error_row

    scratch = scratch_folder(files or {})
    todo = list(tasks)
    try:
        while todo:
            sent = [{**{f.name: getattr(t, f.name) for f in dataclasses.fields(t)
                        if f.name not in ("before", "after")}, "base_dir": scratch} for t in todo]
            request = {"tasks": sent, "trial_cpu": float(trial_seconds),
                       "limits": _limits(process_cpu_limit(len(todo), trial_seconds))}
            child = _Child(scratch, request, trial_wall_limit(trial_seconds))
            try:
                for line in child.lines():
                    if line.strip():
                        row = json.loads(line)
                        todo = [t for t in todo if t.key != row["key"]]
                        yield row
                why = child.finish()
            finally:
                child.close()  # the caller stopped reading early: nothing of it may run on
            if not todo:
                break
            if child.timed_out:
                raise Requeue(f"a trial ran past the wall-clock safety limit ({trial_wall_limit(trial_seconds):g} s)"
                              f" - the machine was too busy or the trial waited on something")
            if child.code == -signal.SIGKILL:
                raise Requeue("the evaluation process was killed from outside")
            task = todo.pop(0)  # the trial it was running ends here; the others run in a new process
            if child.code in (-signal.SIGXCPU, 128 + signal.SIGXCPU):
                row = error_row(task, f"interrupted by {budget_reason(trial_seconds)}: stopped inside a step")
                yield {**row, "outcome": "aborted"}
            else:
                yield error_row(task, f"the evaluation process ended during this trial ({why})")
    finally:
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
    """A new scratch folder holding only ``files`` (``{relative path: text}``); the caller deletes it. Its name
    carries this process's id, so a later worker can tell it was left behind (:func:`remove_stale_scratch`)."""
    scratch = tempfile.mkdtemp(prefix=f"{SCRATCH_PREFIX}{os.getpid()}-")
    try:
        _write_files(scratch, files)
    except BaseException:
        shutil.rmtree(scratch, ignore_errors=True)
        raise
    return scratch


def remove_stale_scratch(folder: str | None = None) -> list[str]:
    """Remove the scratch folders in ``folder`` (the temporary folder) whose process no longer runs (an evaluation
    killed mid-way); returns the folders removed. A folder of a running process is left alone."""
    import psutil

    folder = folder or tempfile.gettempdir()
    removed = []
    try:
        names = os.listdir(folder)
    except OSError:
        return []
    for name in names:
        if not name.startswith(SCRATCH_PREFIX):
            continue
        pid = name[len(SCRATCH_PREFIX):].split("-", 1)[0]
        path = os.path.join(folder, name)
        if psutil.pid_exists(int(pid)) if pid.isdigit() else _younger(path, STALE_UNNAMED):
            continue
        if os.path.isdir(path) and not os.path.islink(path):
            shutil.rmtree(path, ignore_errors=True)
            removed.append(path)
    return removed


def _younger(path: str, seconds: float) -> bool:
    try:
        return time.time() - os.stat(path).st_mtime < seconds
    except OSError:
        return False


def _limits(cpu: int) -> dict[str, int]:
    return {"cpu": cpu, "memory_mb": MEMORY_MB, "file": FILE_LIMIT}


class _Child:
    """The limited child process, started in ``scratch`` with ``request`` on its stdin, in a session of its own;
    killed when ``wall`` seconds pass without a row (:attr:`timed_out`)."""

    def __init__(self, scratch: str, request: dict[str, Any], wall: float) -> None:
        env = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "HOME": scratch, "TMPDIR": scratch,
               "LANG": "C.UTF-8", "MPLBACKEND": "Agg", "PYTHONDONTWRITEBYTECODE": "1"}
        self.proc = subprocess.Popen(sandbox_command(), stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, cwd=scratch, env=env, text=True,
                                     start_new_session=True)
        self.wall, self.timed_out, self.code = wall, False, 0
        self.deadline = time.monotonic() + wall
        self.ended = threading.Event()
        threading.Thread(target=self._watch, daemon=True).start()
        assert self.proc.stdin is not None and self.proc.stderr is not None
        self.err = _Collect(self.proc.stderr)
        self.proc.stdin.write(json.dumps(request))
        self.proc.stdin.close()

    def _watch(self) -> None:
        while not self.ended.wait(max(0.0, min(1.0, self.deadline - time.monotonic()))):
            if time.monotonic() >= self.deadline and self.proc.poll() is None:
                self.timed_out = True
                self.proc.kill()
                return

    def lines(self) -> Iterator[str]:
        """The child's stdout, line by line, as it writes them (each row restarts the wall-clock safety net)."""
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.deadline = time.monotonic() + self.wall
            yield line

    def finish(self) -> str:
        """Wait for the child; why it ended (for messages)."""
        self.code = self.proc.wait()
        self.ended.set()
        self.err.join()
        return _why(self.code, self.err.text)

    def close(self) -> None:
        """Kill the child if it still runs."""
        self.ended.set()
        if self.proc.poll() is None:
            self.proc.kill()
        self.code = self.proc.wait()


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
    if code == -signal.SIGKILL:
        return "killed"
    if code in (-signal.SIGXCPU, 128 + signal.SIGXCPU):
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


def _cpu_soft_limit(seconds: float) -> None:
    """Lower the soft CPU limit to ``seconds`` from now (the kernel sends SIGXCPU there, which ends this process);
    the hard limit set by :func:`apply_limits` stays."""
    import math
    import resource

    used = resource.getrusage(resource.RUSAGE_SELF)
    _, hard = resource.getrlimit(resource.RLIMIT_CPU)
    soft = math.ceil(used.ru_utime + used.ru_stime + seconds)
    if hard != resource.RLIM_INFINITY:
        soft = min(soft, hard)
    resource.setrlimit(resource.RLIMIT_CPU, (soft, hard))


class _CpuWatch(threading.Thread):
    """Stops a simulation once its process has used ``seconds`` more CPU time (every thread's: a renderer's worker
    threads count too, as they do for ``RLIMIT_CPU``)."""

    def __init__(self, sim: Any, seconds: float) -> None:
        super().__init__(daemon=True)
        self.sim, self.seconds = sim, seconds
        self.start_cpu = time.process_time()
        self.done = threading.Event()
        self.start()

    def run(self) -> None:
        while not self.done.wait(CPU_POLL):
            if time.process_time() - self.start_cpu >= self.seconds:
                self.sim.interrupt(budget_reason(self.seconds))
                return


_watch: list[_CpuWatch] = []


def start_cpu_budget(seconds: float, sim: Any, _seed: int) -> None:
    """A trial's ``before`` hook: watch its CPU time from now on (see :func:`official_task`)."""
    stop_cpu_budget(None, None)
    _watch.append(_CpuWatch(sim, seconds))


def stop_cpu_budget(_sim: Any, _result: Any) -> dict[str, Any]:
    """A trial's ``after`` hook: the run ended; no figures of its own (a figure must not depend on the machine)."""
    while _watch:
        _watch.pop().done.set()
    return {}


def _end_with_parent() -> None:
    """End this process when its parent (the queue worker) is gone: nothing of an evaluation outlives it."""
    parent = os.getppid()

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(1.0)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


def main() -> int:
    """The child: limits first, then the trials (one JSON row per line on the original stdout) or the config
    check (one JSON line: ``{"ok": true}`` or the field and message). SIGINT and SIGTERM are held back: only
    its parent stops it (SIGKILL), so a signal can never end a trial as if the submission had stopped."""
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    request = json.loads(sys.stdin.read())
    apply_limits(request["limits"])
    _end_with_parent()
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

    budget = float(request["trial_cpu"])
    for fields in request["tasks"]:
        fields["plugins"] = tuple(fields.get("plugins") or ())
        _cpu_soft_limit(budget + CPU_GRACE)
        row = run_trial_safely(official_task(TrialTask(**fields), budget))
        stop_cpu_budget(None, None)
        out.write(json.dumps(row, separators=(",", ":")) + "\n")
        out.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
