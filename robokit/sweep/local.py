"""The local backend: a pool of ``spawn``-started worker processes, one trial at a time each.

Why not :class:`concurrent.futures.ProcessPoolExecutor` or :class:`multiprocessing.Pool`: neither can kill *one*
hung task (a behaviour stuck in a loop would hang the sweep), and a worker that dies breaks the executor or loses
its task silently. Here each worker has its own pipe; the parent knows which trial each worker runs and since when,
so it can kill exactly the worker whose trial overran ``--trial-timeout``, retry once a trial whose worker died, and
replace the worker. Workers are recycled after ``max_tasks_per_child`` trials (what Python's pools call
``max_tasks_per_child`` / ``maxtasksperchild``), which bounds any slow growth of a long-lived process.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import signal
import time
from collections import deque
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any

from robokit.errors import UserError
from robokit.sweep.trial import TrialTask, error_row

MAX_TASKS_PER_CHILD = 100
"""Default number of trials a worker runs before it is replaced by a fresh process."""


def _worker_main(conn: Connection, plugins: tuple[str, ...], max_tasks: int) -> None:
    """A worker: load the plugins once, then run trials sent over ``conn`` until told to stop or recycled."""
    from robokit.sweep.trial import plugins_for, run_trial_safely, worker_name

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle: it stops the workers
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)  # pybullet prints banners at C level; they must not break the parent's progress bar
    plugins_for(plugins)
    conn.send(("ready", worker_name()))
    for _ in range(max_tasks):
        try:
            task = conn.recv()
        except (EOFError, KeyboardInterrupt):
            return
        if task is None:
            return
        conn.send(("row", run_trial_safely(task)))


@dataclass
class _Worker:
    process: Any
    conn: Connection
    name: str = ""
    ready: bool = False
    done: int = 0
    task: TrialTask | None = None
    started: float = 0.0


class LocalPool:
    """Runs trials on ``workers`` local processes.

    Args:
        workers: Number of processes (default: the number of CPUs).
        trial_timeout: Wall seconds a trial may take once its worker has it; then the worker is killed and the
            trial is recorded as an ``error``. None: no limit.
        max_tasks_per_child: Trials per worker before it is replaced.
        plugins: Extra plugin modules every worker registers.
    """

    def __init__(self, workers: int | None = None, *, trial_timeout: float | None = None,
                 max_tasks_per_child: int = MAX_TASKS_PER_CHILD, plugins: Sequence[str] = ()) -> None:
        self.size = max(1, workers or os.cpu_count() or 1)
        self.timeout = trial_timeout
        self.max_tasks = max(1, max_tasks_per_child)
        self.plugins = tuple(plugins)
        self.ctx = mp.get_context("spawn")
        self.workers: list[_Worker] = []
        self.started_workers = 0
        self.startup_failures = 0

    def _start_worker(self) -> _Worker:
        parent, child = self.ctx.Pipe()
        proc = self.ctx.Process(target=_worker_main, args=(child, self.plugins, self.max_tasks), daemon=True,
                                name=f"robokit-sweep-{self.started_workers}")
        proc.start()
        child.close()
        self.started_workers += 1
        worker = _Worker(proc, parent)
        self.workers.append(worker)
        return worker

    def run(self, tasks: Sequence[TrialTask]) -> Iterator[dict[str, Any]]:
        """Yield one row per task as trials finish (in completion order). Closing the iterator stops the pool."""
        queue: deque[TrialTask] = deque(tasks)
        attempts: dict[str, int] = {}
        try:
            while queue or any(w.task is not None for w in self.workers):
                busy = sum(w.task is not None for w in self.workers)
                while len(self.workers) < min(self.size, len(queue) + busy):
                    self._start_worker()
                for w in self.workers:
                    if w.ready and w.task is None and queue:
                        self._assign(w, queue.popleft())
                yield from self._collect(queue, attempts)
        finally:
            self.close()

    def _assign(self, w: _Worker, task: TrialTask) -> None:
        w.task, w.started = task, time.monotonic()
        w.conn.send(task)

    def _collect(self, queue: deque[TrialTask], attempts: dict[str, int]) -> Iterator[dict[str, Any]]:
        """Wait for the next message, death or timeout; yield any rows it produced."""
        busy = [w for w in self.workers if w.task is not None]
        wait_for = None
        if self.timeout is not None and busy:
            wait_for = max(0.0, min(w.started for w in busy) + self.timeout - time.monotonic())
        handles: list[Any] = [w.conn for w in self.workers] + [w.process.sentinel for w in self.workers]
        wait(handles, timeout=wait_for)
        for w in list(self.workers):
            row = self._poll(w, queue, attempts)
            if row is not None:
                yield row

    def _poll(self, w: _Worker, queue: deque[TrialTask], attempts: dict[str, int]) -> dict[str, Any] | None:
        """Handle what one worker did: a message, its death, or an overrun; return a finished row, if any."""
        try:
            if w.conn.poll():
                kind, payload = w.conn.recv()
                if kind == "ready":
                    w.name, w.ready = payload, True
                    return None
                task, w.task = w.task, None
                w.done += 1
                if w.done >= self.max_tasks:
                    self._replace(w, kill=False)
                return payload if task is not None else None
        except (EOFError, OSError):
            pass  # the pipe broke: the worker died, handled below
        if not w.process.is_alive() or w.conn.closed:
            return self._died(w, queue, attempts)
        if w.task is not None and self.timeout is not None and time.monotonic() - w.started >= self.timeout:
            task = w.task
            elapsed = time.monotonic() - w.started
            self._replace(w, kill=True)
            return error_row(task, f"timed out: no result after {self.timeout:g} s (--trial-timeout); worker "
                                   f"{w.name} killed", worker=w.name, wall_time=elapsed)
        return None

    def _died(self, w: _Worker, queue: deque[TrialTask], attempts: dict[str, int]) -> dict[str, Any] | None:
        """A worker exited: replace it; retry its trial once, then record it as an error."""
        task, code = w.task, w.process.exitcode
        self._replace(w, kill=True)
        if task is None:
            return None
        attempts[task.key] = attempts.get(task.key, 0) + 1
        if attempts[task.key] <= 1:
            queue.appendleft(task)
            return None
        return error_row(task, f"worker died twice running this trial (exit code {code}); not retried again",
                         worker=w.name)

    def _replace(self, w: _Worker, *, kill: bool) -> None:
        """Stop a worker and drop it; the run loop starts a fresh one if there is work left."""
        self._stop(w, kill=kill)
        self.workers.remove(w)
        if not w.ready:
            self.startup_failures += 1
            if self.startup_failures >= 3:
                raise UserError(f"sweep workers die while starting (exit code {w.process.exitcode}); "
                                f"run one trial with `robokit run` to see why")

    def _stop(self, w: _Worker, *, kill: bool) -> None:
        if kill and w.process.is_alive():
            w.process.kill()
        w.process.join(timeout=None if kill else 10)
        if w.process.is_alive():
            w.process.kill()
            w.process.join()
        w.conn.close()

    def close(self) -> None:
        """Stop every worker (idle ones are asked to exit; busy ones are killed)."""
        for w in self.workers:
            if w.task is None and w.process.is_alive():
                try:
                    w.conn.send(None)
                except OSError:
                    pass
        for w in self.workers:
            self._stop(w, kill=w.task is not None)
        self.workers.clear()
